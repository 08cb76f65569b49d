"""Generated code is a budget: what the repository holds, file by file, may not grow past
what is stated here without this test (and the reason) changing with it.

Every line of generated Rust is compiled in each profile, linted and shipped, and a spec
edit regenerates and recompiles it: its size is what makes a system light or heavy to
change. The figures are the lines of each file as generated, with a little room (about
3 %) for a spec's ordinary edits. The repository's target is 100 000 lines in all
(DESIGN.md, "Weight"); the figures below are where it stands on the way there: the
Panda's and ANYmal's collision pairs and their lower bounds are composed (pose kernels +
one chain kernel per family, ``compose=True``), the Panda's self-collision pairs share
the obstacle rows' pose kernels (both boxes in the base frame), and the pose kernels are
assembled along the kinematic tree (one node per joint; a box placed in its link's frame
by numbers); families that call the same primitive the same way share one chain kernel;
a member of a family with parameters whose rows read one link's frame that another
member reads too (the Panda-as-spheres' spheres) is computed on that frame's jet: 116 714
lines in all, from 425 138. Since then: the dynamics outputs walk their tree at run time
(``cbfgen::rigid_body``); the default smooth SAT's chain and bound kernels are the core's
(``generated/ssat.rs``), not each robot's; the ``KERNELS`` tables are one line per kernel
in the core's ``kernel_table!``: 93 318 lines. Then every kernel became generic over the
core's ``Scalar`` (issue 62: the sampled-data certificate runs the same straight line on
intervals), its constants lifted as ``S::from(..)``: the same code, longer lines that rustfmt
wraps, and each module lists its kernels on intervals (``INTERVAL_KERNELS``): 99 788
lines. Then each barrier set states one evaluation's operation count (``evaluation_ops``,
composed and framed rows and the poses they read included) and each walked dynamics its
count (``<output>_ops``): 99 844 lines. Not composed yet: the whole-body models'
feet (ANYmal's foot regions are each alone on their leg's frame, smaller whole).
"""

from __future__ import annotations

from symbolic.codegen.output import REPO_ROOT
from symbolic.generate import builtin_crate_specs

# Lines per generated file, by its path in the repository.
BUDGET = {
    "generated/ssat.rs": 14_300,
    "generated/sphere_box.rs": 260,
    "generated/mod.rs": 20,
    "systems/anymal/generated/anymal.rs": 24_000,
    "systems/anymal_dynamics/generated/anymal_mpc.rs": 13_400,
    "systems/anymal_dynamics/generated/anymal_wbc.rs": 12_400,
    "systems/double_integrator/generated/double_integrator.rs": 540,
    "systems/panda/generated/panda.rs": 8_800,
    "systems/panda_spheres/generated/panda_spheres.rs": 17_500,
    "systems/tachyon3/generated/tachyon3.rs": 11_000,
}
TOTAL = 100_000


def generated_files() -> list[str]:
    core = sorted(p.relative_to(REPO_ROOT).as_posix() for p in (REPO_ROOT / "generated").glob("*.rs"))
    systems = [(crate / "generated" / f"{spec.stem}.rs").relative_to(REPO_ROOT).as_posix()
               for crate, spec in builtin_crate_specs()]
    return core + systems


def lines(path: str) -> int:
    return len((REPO_ROOT / path).read_text().splitlines())


def test_every_generated_file_has_a_budget():
    assert sorted(generated_files()) == sorted(BUDGET)


def test_each_file_is_within_its_budget():
    over = {p: (lines(p), BUDGET[p]) for p in generated_files() if lines(p) > BUDGET[p]}
    assert not over, f"generated files past their budget (lines, budget): {over}"


def test_the_repository_is_within_its_total():
    total = sum(lines(p) for p in generated_files())
    assert total <= TOTAL, f"{total} generated lines, budget {TOTAL}"
