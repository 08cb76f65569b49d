"""Generation is deterministic and the emitter prints what it is given."""

import os
import subprocess
import sys

import numpy as np
import symengine as se

from symbolic.codegen.backends.rust.emitter import RustPrinter, emit_kernel, float_literal
from symbolic.generate import REPO_ROOT, render
from symbolic.inputs_hash import input_files, inputs_hash
from symbolic.kernel import Kernel


def _render_in_subprocess(seed: str) -> str:
    code = "from symbolic.generate import render; import sys; sys.stdout.write(render()['ssat.rs'])"
    env = {**os.environ, "PYTHONHASHSEED": seed}
    return subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, env=env,
                          capture_output=True, text=True, check=True).stdout


def test_render_is_byte_identical_across_processes_and_hash_seeds():
    assert _render_in_subprocess("1") == _render_in_subprocess("12345") == render()["ssat.rs"]


def test_inputs_hash_covers_sources_but_not_tests():
    names = {p.relative_to(REPO_ROOT).as_posix() for p in input_files(REPO_ROOT)}
    assert "symbolic/families/ssat.py" in names and "symbolic/requirements.txt" in names
    assert not any("/tests/" in n or "__pycache__" in n for n in names)
    assert len(inputs_hash(REPO_ROOT)) == 64


def test_float_literals_round_trip():
    rng = np.random.default_rng(3)
    for v in np.concatenate([rng.normal(size=200) * 10.0 ** rng.integers(-300, 300, 200), [0.0, 1.0, 2.0, 1e16]]):
        text = float_literal(float(v))
        assert float(text) == float(v)
        assert "." in text or "e" in text  # a float literal, never an integer one


# The core's scalar trait, for kernels compiled alone by rustc, over libm stand-ins for the
# runtime's lanes.
SCALAR_MODULE = (
    f'#[path = "{REPO_ROOT / "src" / "scalar.rs"}"] pub mod scalar;\n'
    "pub mod lanes { pub fn tanh<const N: usize>(v: [f64; N]) -> [f64; N] { v.map(f64::tanh) } "
    "pub fn exp<const N: usize>(v: [f64; N]) -> [f64; N] { v.map(f64::exp) } "
    "pub fn ln<const N: usize>(v: [f64; N]) -> [f64; N] { v.map(f64::ln) } "
    "pub fn tanh1(v: f64) -> f64 { v.tanh() } pub fn exp1(v: f64) -> f64 { v.exp() } "
    "pub fn ln1(v: f64) -> f64 { v.ln() } }\n")


def test_integer_powers_become_products():
    x, y = se.symbols("x y")
    p = RustPrinter({x: "x", y: "y"})
    assert p(x ** 2) == "x.sqr()"
    assert "powf" not in p(x ** 8) and "powi" not in p(x ** 8)
    assert p(x ** -1) == "S::from(1.0) / x"
    assert p(se.sqrt(x)) == "x.sqrt()"
    assert "powf" not in p((x + y) ** 5)


def test_kernel_signature_and_unpacking():
    k = Kernel("probe", "A probe kernel.")
    v = k.array_input("v", "xy", "a vector")
    s = k.scalar_input("s", "a scalar")
    k.output_vector("out", [se.tanh(s * v[0]) * v[1] ** 3, se.log(v[1] ** 2 + 1) / (v[0] - 3)], "outputs")
    text = emit_kernel(k, "cbfgen")
    # Generic over the scalar: f64 for the filter, intervals for the sampled-data certificate.
    assert "pub fn probe<S: cbfgen::scalar::Scalar>(v: &[S; 2], s: S) -> [S; 2] {" in text
    assert "let v_x = v[0];" in text and "let v_y = v[1];" in text
    # Lone transcendental calls take the runtime's bounded one-argument forms, not libm's.
    assert "S::tanh_lane(" in text and "S::ln_lane(" in text
    assert ".tanh()" not in text and ".ln()" not in text and "powf" not in text


def test_independent_transcendental_calls_are_batched_by_depth():
    from symbolic.codegen.straight_line import straight_line

    k = Kernel("batched", "Three tanh, two exp over them, one log over those.")
    v = k.array_input("v", "xyz", "a vector")
    a = k.scalar_input("a", "a sharpness")
    t = [se.tanh(a * c) * c for c in v]
    e = [se.exp(t[0] - t[1]), se.exp(t[2] * v[0])]
    k.output_scalar("out", se.log(e[0] + e[1] + 1) + t[0], "a value")
    code = straight_line(k)
    batches = [(s.function, len(s.symbols)) for s in code.steps if s.kind == "lanes"]
    assert batches == [("tanh", 3), ("exp", 2), ("log", 1)]
    # Every batch comes after all its arguments' definitions and before any use.
    defined = {sym for inp in k.inputs for sym in inp.symbols}
    for step in code.steps:
        for r in step.rhs:
            assert r.free_symbols <= defined, step
        defined |= set(step.symbols or (step.symbol,))
    text = emit_kernel(k, "crate")
    assert text.count("S::tanh_lanes([") == 1 and text.count("S::exp_lanes([") == 1
    assert text.count("S::ln_lane(") == 1


def test_doc_text_escapes_brackets_outside_code_spans_only():
    """Units such as [m] would be rustdoc intra-doc links; code spans stay verbatim."""
    from symbolic.codegen.backends.rust.emitter import rustdoc_text

    assert rustdoc_text("height [m], rate [1/s]") == "height \\[m\\], rate \\[1/s\\]"
    assert rustdoc_text("`lie[i]` is [h, L_f h]") == "`lie[i]` is \\[h, L_f h\\]"
    assert rustdoc_text("no brackets") == "no brackets"


def test_a_literal_temporary_compiles(tmp_path):
    # sin and cos of one constant angle share a CSE temporary printed as a constant; it must be
    # the kernel's scalar for `.sin()` to resolve.
    k = Kernel("literal", "A kernel with a constant angle.")
    v = k.array_input("v", "xy", "a vector")
    angle = se.RealDouble(0.25) * se.pi  # stays symbolic until printed
    k.output_vector("out", [se.sin(angle) * v[0] + se.cos(angle) * v[1], se.cos(angle) * v[0]], "outputs")
    source = tmp_path / "literal.rs"
    source.write_text(SCALAR_MODULE + emit_kernel(k, "crate"))
    done = subprocess.run(["rustc", "--edition", "2021", "--crate-type", "lib", "--emit", "metadata",
                           "-o", str(tmp_path / "literal.rmeta"), str(source)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_a_kernel_too_deep_for_rustc_is_refused():
    from symbolic.codegen.backends.rust.emitter import MAX_KERNEL_LEVELS
    from symbolic.spec import SpecError

    k = Kernel("deep", "A chain of distinct temporaries longer than rustc can nest.")
    v = k.array_input("v", "xy", "a vector")
    e = v[0]
    outs = []
    for i in range(MAX_KERNEL_LEVELS + 10):
        e = se.sin(e + i * v[1])
        outs.append(e)
    k.output_vector("out", outs, "every link of the chain")
    try:
        emit_kernel(k, "crate")
    except SpecError as exc:
        assert "over=[...]" in str(exc)
    else:
        raise AssertionError("a kernel with more locals than rustc can nest was emitted")


def test_a_family_acting_through_one_one_sided_input_is_warned_about(tmp_path):
    # The quadrotor's speed limit and floor both act only through thrust >= 0 (issue 32):
    # generating it prints one warning per family, naming the input, its limits and the
    # family it competes with, for cbfgen-build to show as cargo warnings, and the
    # module's docs carry them. A spec whose families have two-sided inputs gets none.
    specs = REPO_ROOT / "symbolic" / "tests" / "specs"
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(specs / "planar_quadrotor.py"),
                           "--out", str(tmp_path)], cwd=REPO_ROOT, capture_output=True, text=True, check=True)
    warnings = [line for line in done.stdout.splitlines() if line.startswith("warning ")]
    assert len(warnings) == 2, done.stdout
    assert "family 'speed_limit'" in warnings[0] and "'thrust'" in warnings[0] and "[0, 19.62]" in warnings[0]
    assert "shares 'thrust' with ['floor']" in warnings[0] and "share its priority 0" in warnings[0]
    assert "family 'floor'" in warnings[1]
    assert (tmp_path / "planar_quadrotor.rs").read_text().count("Warning from the generator") == 2
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(specs / "planar_robot.py"),
                           "--out", str(tmp_path)], cwd=REPO_ROOT, capture_output=True, text=True, check=True)
    assert not [line for line in done.stdout.splitlines() if line.startswith("warning ")], done.stdout


def test_a_kernel_cut_in_two_keeps_every_step_and_every_bit(tmp_path):
    # A family evaluated at many instances per state is emitted as <k>_state (state only),
    # <k>_instance and <k> (the two in a row). The cut puts every state-only step first,
    # splits a lane batch whose arguments fall on both sides, and the split kernel returns
    # the one-function kernel's bits: both are compiled and run here on 1 000 inputs.
    from symbolic.codegen.backends.rust.emitter import emit_split_kernel
    from symbolic.codegen.straight_line import split, straight_line

    def build(name: str) -> Kernel:
        k = Kernel(name, "A state part and an instance part.")
        x = k.array_input("x", ["a", "b"], "state")
        c = k.array_input("c", ["u", "v"], "an instance's parameters")
        pose = [k.let_("pose0", se.sin(x[0]) * x[1]), k.let_("pose1", se.cos(x[0]) + x[1] ** 2)]
        t = [se.tanh(pose[0]), se.tanh(pose[1] * 2), se.tanh(c[0] * pose[0] - c[1])]  # one batch, both sides
        k.output_vector("out", [t[0] * t[2] + se.exp(c[1] * t[1]), pose[0] * c[0] + t[1]], "outputs")
        return k

    code = straight_line(build("probe"))
    x_symbols = set(build("probe").inputs[0].symbols)
    cut = split(code, [s for s in code.used_inputs if str(s).startswith("x_")])
    state_defined = set()
    for step in cut.state_steps:
        for r in step.rhs:
            assert r.free_symbols <= x_symbols | state_defined, step
        state_defined |= set(step.symbols or (step.symbol,))
    tanh_batches = [len(s.symbols) for s in cut.state_steps + cut.instance_steps if s.function == "tanh"]
    assert sorted(tanh_batches) == [1, 2], "the mixed tanh batch is split: two on the state side, one not"
    assert len(cut.state_steps) + len(cut.instance_steps) == len(code.steps) + 1

    program = "\n".join([
        SCALAR_MODULE, emit_split_kernel(build("probe"), "crate", ["x"]), emit_kernel(build("whole"), "crate"),
        "fn main() { let mut s = 1u64; let mut r = || { s = s.wrapping_mul(6364136223846793005).wrapping_add(1); "
        "((s >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0 };",
        "  for _ in 0..1000 { let x = [r(), r()]; let c = [r(), r()];",
        "    let (a, b) = (probe(&x, &c), whole(&x, &c));",
        "    let state = probe_state(&x); for _ in 0..2 { assert_eq!(probe_instance(&state, &c).map(f64::to_bits), "
        "a.map(f64::to_bits)); }",
        "    assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits)); } println!(\"same bits\"); }",
    ])
    source = tmp_path / "split.rs"
    source.write_text(program)
    built = subprocess.run(["rustc", "--edition", "2021", "-O", "-o", str(tmp_path / "split"), str(source)],
                           capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    ran = subprocess.run([str(tmp_path / "split")], capture_output=True, text=True)
    assert ran.returncode == 0 and "same bits" in ran.stdout, ran.stderr


def test_evaluation_ops_sums_the_stated_counts_of_the_calls_evaluate_makes():
    # `evaluation_ops` states what `evaluate` performs in its kernels with every slot filled:
    # a fixed family's (speed_limit, one instance) whole kernel once, a capacity family's
    # (wall) state part once and instance part per slot, their sum the kernel's own stated
    # count. (The Rust tests of Tachyon 3 and the double integrator count them as they run.)
    import re

    from symbolic.codegen.generate import render

    _, text = render(REPO_ROOT / "symbolic" / "tests" / "specs" / "planar_robot.py")
    stated = {m[1]: [int(v) for v in m[2].split(",")]
              for m in re.finditer(r"^    (\w+)\(.*\) ops \[([\d, ]+)\];$", text, re.MULTILINE)}
    method = text[text.index("fn evaluation_ops"):text.index("fn evaluate(")]
    counts = [[0] * 8 if m == "OpCount::ZERO" else [int(v) for v in m[len("OpCount::new(["):-2].split(",")]
              for m in re.findall(r"OpCount::ZERO|OpCount::new\(\[[\d, ]+\]\)", method)]
    assert len(counts) == 3 and "c.wall)" in method, method
    fixed, wall_state, wall_instance = counts
    assert fixed == stated["speed_limit"]
    assert [a + b for a, b in zip(wall_state, wall_instance, strict=True)] == stated["wall"]
    assert sum(wall_instance) > 0
