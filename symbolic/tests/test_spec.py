"""The spec API and the system generator: degrees found, mistakes named, output
deterministic, include!-able and compiling against the runtime's traits."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import symengine as se

from symbolic import primitives as prim
from symbolic.codegen.definition import define
from symbolic.codegen.generate import render
from symbolic.generate import REPO_ROOT
from symbolic.spec import MAX_INPUT, SpecError, System, load

SPECS = Path(__file__).resolve().parent / "specs"
PLANAR = SPECS / "planar_robot.py"
TRIPLE = SPECS / "triple_integrator.py"
DOUBLE = REPO_ROOT / "systems" / "double_integrator" / "spec" / "double_integrator.py"


# ------------------------------------------------------------------ definitions
def test_relative_degrees_are_found_per_family():
    planar = define(load(PLANAR))
    assert {f.name: f.degree for f in planar.families} == {"speed_limit": 1, "wall": 2}
    assert planar.families[0].columns == ((0, 1),) and planar.families[1].columns == ((0, 1),)
    assert not planar.time_varying
    triple = define(load(TRIPLE))
    assert [(f.name, f.degree, f.poles) for f in triple.families] == [("position_limit", 3, (3.0, 4.0, 5.0))]
    double = define(load(DOUBLE))
    assert [(f.name, f.degree, f.time) for f in double.families] == [("sine_barrier", 2, True)]
    assert double.input_limits[0].upper == MAX_INPUT


def _demo(**family) -> System:
    s = System("demo")
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    s.family("limit", family.pop("h", lambda prm: 1 - p), **family)
    return s


def test_default_poles_repeat_to_the_degree_found():
    fam = define(_demo()).families[0]
    assert fam.degree == 2 and fam.poles == (10.0, 10.0)


def test_an_output_takes_the_inputs_only_when_it_says_so():
    s = _demo()
    p, v = s.x
    (u,) = s.u
    with pytest.raises(SpecError, match="depends on the states only"):
        s.output("power", [("power", v * u, "u v")], doc="the input's power")
    s.output("flow", [("xdot", [v, u], "x'"), ("b", [[0], [1]], "dx'/du")], doc="x' and its Jacobian", inputs=True)
    with pytest.raises(SpecError, match="depends on the states and inputs only"):
        s.output("stray", [("w", se.Symbol("w") * u, "?")], doc="a stray symbol", inputs=True)
    (kernel,) = define(s).outputs
    assert [i.name for i in kernel.inputs] == ["x", "u"]
    # The kernel's values at a point are the expressions' (u is the kernel's input).
    assert kernel.evaluate({"x": [0.5, 2.0], "u": [3.0]})["xdot"] == [2.0, 3.0]


def test_defaults_are_shaped_as_their_parameters_and_the_rest_start_unset():
    s = System("demo")
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    s.family("limit", lambda prm: prm.p_max - prm.n[0] * p + prm.m[0][1],
             params={"p_max": (), "n": (2,), "m": (2, 2)}, defaults={"n": [1.0, 0.5], "m": [[1, 2], [3, 4]]})
    fam = define(s).families[0]
    # Matrices row by row, as the kernels read them.
    assert {q.name: q.default for q in fam.params} == {"p_max": None, "n": (1.0, 0.5), "m": (1.0, 2.0, 3.0, 4.0)}


@pytest.mark.parametrize("defaults, extra, message", [
    ({"nope": 1.0}, {}, "defaults name ['nope'], not parameters of the family (['p_max'])"),
    ({"p_max": [1.0]}, {}, "default of 'p_max' must be a number of shape (), got [1.0]"),
    ({"p_max": float("nan")}, {}, "default of 'p_max' must be finite"),
    ({"p_max": 1e7}, {}, "default of 'p_max' must be finite and within +-1e6, got 10000000.0"),
    ({"p_max": "1"}, {}, "default of 'p_max' must be a number"),
    ({"p_max": 1.0}, {"capacity": True}, "defaults are for fixed instances"),
    ([1.0], {}, "defaults must be a dict"),
])
def test_bad_defaults_name_the_family_and_parameter(defaults, extra, message):
    with pytest.raises(SpecError) as err:
        _demo(h=lambda prm: prm.p_max, params={"p_max": ()}, defaults=defaults, **extra)
    assert message in str(err.value) and "family 'limit'" in str(err.value), str(err.value)


def test_several_rows_per_instance_and_let_names_made_unique():
    s = System("boxes")
    px, py, vx, vy = s.states(["px", "py", "vx", "vy"])
    s.inputs(["ax", "ay"], limits=[(-1, 1), (-1, 1)])
    s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
    robot = prim.Box([px, py, 0], prim.identity(), [0.1, 0.1, 0.1])

    def two_walls(p):
        a = prim.Box(p.a, prim.identity(), [1, 1, 1])
        b = prim.Box(p.b, prim.rot_z(p.yaw), [1, 1, 1])
        return [("a", prim.ssat(p, a, robot)), ("b", prim.ssat(p, b, robot)),
                ("floor", prim.half_space([px, py], [0, 1], -p.yaw))]

    s.family("walls", two_walls, params={"a": (3,), "b": (3,), "yaw": ()}, count=2)
    fam = define(s).families[0]
    assert fam.row_names == ("a", "b", "floor") and fam.degree == 2 and fam.count == 2
    names = [str(d.symbol) for d in fam.kernels[0].definitions]
    assert "t_x" in names and "t_x_2" in names and "y_max_2" in names


@pytest.mark.parametrize("build, message", [
    (lambda: System("Demo"), "system: name 'Demo' is not a snake_case identifier"),
    (lambda: System("state"), "system: name 'state' is the name of an item"),
    (lambda: _demo(poles=[1.0]), "family 'limit': poles has 1 entries but the relative degree found is 2"),
    (lambda: _demo(poles=[1.0, 1e5]), "family 'limit': poles [100000.0] outside [1e-06, 10000] 1/s"),
    (lambda: _demo(priority=16), "family 'limit': priority must be an integer in [0, 15]"),
    (lambda: _demo(priority=1.0), "family 'limit': priority must be an integer in [0, 15]"),
    (lambda: _demo(activation=0.0), "family 'limit': activation 0.0 must be > 0"),
    (lambda: _demo(h=lambda p: se.Integer(3)), "family 'limit': row 'limit' depends on no state"),
    (lambda: _demo(h=lambda p: p.q), "family 'limit': no parameter 'q' (declared: none)"),
    (lambda: _demo(h=lambda p: se.Symbol("x_p") - se.Symbol("t")), "uses ['t'], which are not states or "
     "declared parameters (declare the family with time=True to use t)"),
    (lambda: _demo(h=lambda p: se.Symbol("x_p") - se.Symbol("u_u")), "never on inputs"),
    (lambda: _demo(time=True), "declared time=True but h does not depend on t"),
    (lambda: _demo(params={"q": ()}), "parameters ['q'] are declared but h does not use them"),
    (lambda: _demo(params={"x": ()}), "family 'limit': parameter 'x' is reserved in generated code"),
    (lambda: _demo(params={"fn": ()}), "parameter 'fn' is reserved"),
    (lambda: _demo(params={"q": (0,)}), "parameter 'q' has shape (0,)"),
    (lambda: _demo(count=2), "count=2 without params gives 2 identical rows"),
    (lambda: _demo(capacity=True), "capacity=True needs params"),
    (lambda: _demo(params={"q": ()}, capacity=True, count=1), "give count or capacity=True, not both"),
    (lambda: _demo(count=20_000, params={"q": ()}), "count must be an integer in [1, 10000]"),
    (lambda: _demo(h=lambda p: [("a", se.Symbol("x_p")), ("b", se.Symbol("x_v"))]),
     "family 'limit': its rows have different relative degrees"),
    (lambda: _demo(h=lambda p: [("a", se.Symbol("x_p")), ("a", se.Symbol("x_p"))]), "row names ['a', 'a'] repeat"),
    (lambda: _demo(lower_bound=lambda p: 0), "lower_bound skips instances above the activation threshold; it "
     "needs a finite activation"),
    (lambda: _demo(h=lambda p: p.q - se.Symbol("x_p"), params={"q": ()}, capacity=True, lower_bound=lambda p: 0),
     "needs a finite activation"),
    (lambda: _demo(h=lambda p: p.q - se.Symbol("x_p"), params={"q": ()}, capacity=True, activation=1.0,
                   lower_bound=lambda p: [p.q]), "lower_bound: returns one expression"),
    (lambda: _demo(h=lambda p: p.q - se.Symbol("x_p"), params={"q": ()}, capacity=True, activation=1.0,
                   lower_bound=lambda p: se.Symbol("u_u")), "lower_bound: uses ['u_u'], which are not states"),
])
def test_spec_errors_name_system_family_and_key(build, message):
    with pytest.raises(SpecError) as err:
        define(build())
    assert message in str(err.value)
    assert "system 'demo'" in str(err.value) or message.startswith("system: ")


def test_layout_errors():
    s = System("demo")
    s.states(["p", "v"])
    with pytest.raises(SpecError, match="limits of input 'u' are \\(1.0, -1.0\\)"):
        s.inputs(["u"], limits=[(1.0, -1.0)])
    with pytest.raises(SpecError, match="within \\+-1e\\+06"):
        s.inputs(["u"], limits=[(-2e6, 1.0)])
    with pytest.raises(SpecError, match="must be finite"):
        s.inputs(["u"], limits=[(-float("inf"), 1.0)])
    with pytest.raises(SpecError, match="one \\(lower, upper\\) pair per input"):
        s.inputs(["u", "w"], limits=[(-1.0, 1.0)])
    with pytest.raises(SpecError, match="system 'other': state 'a b' is not a snake_case"):
        System("other").states(["a b"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    with pytest.raises(SpecError, match="dynamics f must have one entry per state \\(2\\)"):
        s.dynamics(f=[0], g=[[0], [1]])
    with pytest.raises(SpecError, match="dynamics g must be 2 rows \\(states\\) of 1 entries"):
        s.dynamics(f=[0, 0], g=[[0, 1], [1, 0]])
    with pytest.raises(SpecError, match="dynamics f\\[0\\] = t uses \\['t'\\]"):
        s.dynamics(f=[se.Symbol("t"), 0], g=[[0], [1]])
    with pytest.raises(SpecError, match="no dynamics declared"):
        define(s)


def test_relative_degree_above_four_is_an_error():
    s = System("chain")
    xs = s.states([f"s{i}" for i in range(6)])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=xs[1:] + [0], g=[[0]] * 5 + [[1]])
    s.family("far", lambda p: xs[0])
    with pytest.raises(SpecError, match="family 'far': relative degree > 4"):
        define(s)


def test_spec_file_errors(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("x = 1\n")
    with pytest.raises(SpecError, match="defines no build\\(\\) function"):
        load(bad)
    bad.write_text("def build():\n    return 3\n")
    with pytest.raises(SpecError, match="returned int, not a System"):
        load(bad)
    with pytest.raises(SpecError, match="no such file"):
        load(tmp_path / "missing.py")


# ---------------------------------------------------------------------- output
def _render_in_subprocess(seed: str) -> str:
    code = (f"import sys; from symbolic.codegen.generate import render; "
            f"sys.stdout.write(render({str(PLANAR)!r})[1])")
    env = {**os.environ, "PYTHONHASHSEED": seed}
    return subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, env=env,
                          capture_output=True, text=True, check=True).stdout


def test_generation_is_byte_deterministic():
    name, text = render(PLANAR)
    assert name == "planar_robot.rs"
    assert render(PLANAR)[1] == text == _render_in_subprocess("1") == _render_in_subprocess("4242")


def test_output_is_includable_and_headed_by_its_inputs_hash(tmp_path):
    _, text = render(PLANAR)
    lines = text.splitlines()
    assert lines[0].startswith("// @generated")
    assert re.fullmatch(r"// inputs-sha256: [0-9a-f]{64}", lines[1])
    assert lines[2] == ("// Spec: symbolic/tests/specs/planar_robot.py (system `planar_robot`, "
                        "runtime crate `cbfgen`)")
    assert "#![" not in text and "//!" not in text
    for item in ["pub struct PlanarRobot;", "pub struct WallParams {", "pub struct SpeedLimitParams {",
                 "pub speed_limit: [SpeedLimitParams; 1],", "pub wall: cbfgen::system::Instances<WallParams>,",
                 "pub rotation: cbfgen::nalgebra::SMatrix<f64, 3, 3>,",
                 "pub center: cbfgen::nalgebra::SVector<f64, 3>,",
                 "cbfgen::kernel_table! {", "pub type Filter =",
                 "pub fn default_settings() -> cbfgen::filter::FilterSettings<NU>",
                 "pub const PX: usize = 0;", "pub const AY: usize = 1;"]:
        assert item in text, item
    # Another spec text or runtime path: another hash.
    copy = tmp_path / "planar_robot.py"
    copy.write_text(PLANAR.read_text() + "\n# edited\n")
    assert render(copy)[1].splitlines()[1] != lines[1]
    inside = render(PLANAR, "crate")[1]
    assert inside.splitlines()[1] != lines[1]
    assert "crate::system::BarrierSet<NU>" in inside and "cbfgen::" not in inside
    with pytest.raises(SpecError, match="not a Rust path"):
        render(PLANAR, "my crate")


def test_command_line_writes_and_checks(tmp_path):
    run = [sys.executable, "-m", "symbolic", "generate", str(TRIPLE), "--out", str(tmp_path)]
    done = subprocess.run(run, cwd=REPO_ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    target = tmp_path / "triple_integrator.rs"
    assert target.read_text() == render(TRIPLE)[1]
    assert subprocess.run(run + ["--check"], cwd=REPO_ROOT).returncode == 0
    target.write_text(target.read_text() + "// edited\n")
    assert subprocess.run(run + ["--check"], cwd=REPO_ROOT, capture_output=True).returncode == 1
    bad = tmp_path / "bad.py"
    bad.write_text("def build():\n    return 3\n")
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(bad), "--out", str(tmp_path)],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    assert done.returncode == 2 and "error: spec" in done.stderr


SPEC_WITH_FAMILY = '''import symengine as se

from symbolic.spec import System


def build() -> System:
    s = System("oops")
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    {family}
    return s
'''
FAMILY_LINE = 11  # the {family} line above


@pytest.mark.parametrize("h, says", [
    # A bug in the spec's own code: its type and message, at the line that raised it.
    ("1 - p + undefined_thing", "NameError: name 'undefined_thing' is not defined"),
    ("[1 - p][3]", "IndexError: list index out of range"),
    # A function the Lie derivatives cannot go through: named, with a smooth form to use.
    ("1 - se.Abs(p)", "family 'limit': h uses abs(x_p), which is not differentiable everywhere, and its Lie "
                      "derivatives cannot be taken; write it as sqrt(e**2 + eps**2)"),
    ("1 - se.Max(p, v)", "h uses max(x_p, x_v), which is not differentiable everywhere"),
    # A SpecError found while differentiating: at the family's declaration.
    ("1 + 0 * p", "family 'limit': row 'limit' depends on no state"),
])
def test_a_spec_error_names_the_spec_file_and_line(tmp_path, h, says):
    spec = tmp_path / "oops.py"
    spec.write_text(SPEC_WITH_FAMILY.format(family=f's.family("limit", lambda prm: {h}, poles=[5.0, 5.0])'))
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(spec), "--out", str(tmp_path)],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2
    assert last.startswith(f"error: {spec}:{FAMILY_LINE}: ") and says in last, last


def test_interval_rows_keep_each_value_between_its_bounds():
    a, b = se.symbols("a b")
    rows = prim.interval_rows(["a", "b"], [a, b], [-1.0, 0.5], [2.0, 3.0])
    assert [name for name, _ in rows] == ["a_min", "a_max", "b_min", "b_max"]
    assert [e.subs({a: 0.0, b: 1.0}) for _, e in rows] == [1.0, 2.0, 0.5, 2.0]
    with pytest.raises(ValueError, match="2 names, 1 values"):
        prim.interval_rows(["a", "b"], [a], [0.0, 0.0], [1.0, 1.0])




@pytest.mark.parametrize("family, says", [
    # Extended class-K functions: odd, increasing, through 0, of s alone.
    ("s.family('limit', lambda q: 1 - p, class_k=lambda a: a + a**2)",
     "family 'limit', class_k: alpha(s) = s + s**2 is not odd"),
    ("s.family('limit', lambda q: 1 - p, class_k=lambda a: a**3 + 1)",
     "family 'limit', class_k: alpha(0) = 1, not 0"),
    ("s.family('limit', lambda q: 1 - p, class_k=lambda a: -a)",
     "family 'limit', class_k: alpha(s) = -s is not increasing"),
    ("s.family('limit', lambda q: 1 - p, class_k=lambda a: a * p)",
     "family 'limit', class_k: alpha(s) = s*x_p uses ['x_p']; it is a function of s alone"),
    ("s.family('limit', lambda q: 1 - p, class_k=3.0)", "family 'limit': class_k must be a function of one symbol"),
    # A CLF: V' must depend on the input, and it never shares tier 0.
    ("s.lyapunov('goal', lambda q: p**2, rate=1.0)",
     "family 'goal': V' does not depend on the input (relative degree 2)"),
    ("s.lyapunov('goal', lambda q: v**2, rate=1.0, priority=0)",
     "lyapunov 'goal': priority must be an integer in [1, 15]"),
    # A keyword of an older release: what replaced it; one never known: named.
    ("s.family('limit', lambda q: 1 - p, slack_weight=100.0)",
     "family 'limit': slack_weight= was removed; priorities replaced slack weights: give the family priority=N"),
    ("s.lyapunov('goal', lambda q: v**2, rate=1.0, slack_weight=1.0)",
     "lyapunov 'goal': slack_weight= was removed; priorities replaced slack weights"),
    ("s.family('limit', lambda q: 1 - p, pole=[1.0])", "family 'limit': no keyword pole="),
])
def test_class_k_and_lyapunov_mistakes_name_the_family_and_the_line(tmp_path, family, says):
    spec = tmp_path / "oops.py"
    spec.write_text(SPEC_WITH_FAMILY.format(family=family))
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(spec), "--out", str(tmp_path)],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2
    assert last.startswith(f"error: {spec}:{FAMILY_LINE}: ") and says in last, last


@pytest.mark.parametrize("objective, says", [
    ("s.objective(P=[[1 + p**2, 0]])", "objective: P must be 1 x 1: a list of 1 rows of 1 entries"),
    ("s.objective(P=[[1 + se.Symbol('k')**2]])", "objective, P[0][0]: uses ['k']; it depends on the states only"),
    ("s.objective(P=[[0]])", "objective: P[0][0] = 0: a positive definite P has a positive diagonal"),
    ("s.objective(P=[[1]], q=[p, v])", "objective: q must be a list of 1 entry (one per input)"),
])
def test_objective_mistakes_name_the_line(tmp_path, objective, says):
    spec = tmp_path / "oops.py"
    spec.write_text(SPEC_WITH_FAMILY.format(family=objective))
    done = subprocess.run([sys.executable, "-m", "symbolic", "generate", str(spec), "--out", str(tmp_path)],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 2
    assert last.startswith(f"error: {spec}:{FAMILY_LINE}: ") and says in last, last


def test_an_objective_must_be_symmetric_and_becomes_a_kernel_of_the_state():
    s = System("cost")
    px, vx = s.states(["px", "vx"])
    s.inputs(["a", "b"], limits=[(-1.0, 1.0), (-1.0, 1.0)])
    s.dynamics(f=[vx, 0], g=[[0, 0], [1, 1]])
    with pytest.raises(SpecError, match=r"P is not symmetric: P\[0\]\[1\] = x_vx but P\[1\]\[0\] = 2\*x_vx"):
        s.objective(P=[[2, vx], [2 * vx, 2]])
    s.objective(P=[[2, vx * px], [px * vx, 1 + vx**2]], q=[px, 0])
    s.family("wall", lambda q: 1 - px, poles=[2.0, 2.0])
    with pytest.raises(SpecError, match="objective: declared twice"):
        s.objective(P=[[1, 0], [0, 1]])
    kernel = define(s).objective
    # Evaluated by SymEngine at a point, against the formulas by hand.
    values = kernel.evaluate({"x": [0.5, 2.0]})
    assert values["p"] == pytest.approx([2.0, 1.0, 1.0, 5.0]) and values["q"] == pytest.approx([0.5, 0.0])


def test_a_lyapunov_family_is_the_barrier_of_minus_v_below_the_safety_rows():
    s = System("goal")
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    s.family("wall", lambda q: 1 - p, poles=[2.0, 2.0])
    s.lyapunov("speed", lambda q: (v - q.v_goal) ** 2, rate=3.0, params={"v_goal": ()})
    wall, speed = define(s).families
    assert (wall.kind, speed.kind) == ("barrier", "lyapunov")
    assert (speed.degree, speed.poles, speed.priority) == (1, (3.0,), 15)
    # Its row is h = -V: [h, L_f h] and L_g h at a point, against V's derivatives by hand.
    values = speed.kernels[0].evaluate({"x": [0.3, 1.5], "v_goal": 0.5})
    assert values["lie"] == pytest.approx([-(1.5 - 0.5) ** 2, 0.0])
    assert values["lg_lf"] == pytest.approx([-2.0 * (1.5 - 0.5)])


def test_partial_functions_of_what_can_reach_zero_are_reported_with_a_guarded_form():
    from symbolic.spec import Positive

    s = System("partial")
    p, v = s.states(["p", "v"])
    s.inputs(["u"], limits=[(-1.0, 1.0)])
    s.dynamics(f=[v, 0], g=[[0], [1]])
    s.family("root", lambda q: 1 - se.sqrt(p), poles=[5.0, 5.0])
    s.family("ratio", lambda q: 1 - 1 / (p - q.a), params={"a": ()}, poles=[5.0, 5.0])
    s.family("logged", lambda q: se.log(v + 2), poles=[5.0])
    # Provably >= 0 from their form: a sum of squares, a Positive parameter, exp.
    s.family("fine", lambda q: 1 - se.sqrt(p**2 + v**2) - 1 / q.r + se.log(se.exp(p) + 1),
             params={"r": ((), Positive)}, poles=[5.0])
    root, ratio, logged, fine = define(s).families
    assert len(root.warnings) == 1 and "family 'root': h uses sqrt(x_p)" in root.warnings[0]
    assert "Write sqrt(x_p + eps**2)" in root.warnings[0]
    assert len(ratio.warnings) == 1 and "family 'ratio': h uses 1 / (-a + x_p)" in ratio.warnings[0]
    assert "(-a + x_p) / ((-a + x_p)**2 + eps**2)" in ratio.warnings[0]
    assert len(logged.warnings) == 1 and "h uses log(2 + x_v)" in logged.warnings[0]
    assert fine.warnings == ()


def test_no_built_in_system_has_a_partial_function_warning():
    # Their square roots are of sums of squares and their divisions by Positive lengths:
    # a warning here would be noise in every user's build of them.
    for spec in sorted((REPO_ROOT / "systems").glob("*/spec/*.py")):
        if spec.stem == spec.parent.parent.name:
            for f in define(load(spec)).families:
                assert not [w for w in f.warnings if "not provably >= 0" in w], (spec, f.warnings)
