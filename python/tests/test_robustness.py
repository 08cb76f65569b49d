"""Issue 12's fuzz findings that reach Python, as regression tests.

Each bad input must raise a typed exception (``cbfgen.CbfError``, ``ValueError``,
``OverflowError``), never ``PanicException``, and must leave the process alive and the
filter usable; no call may hand back a NaN or an infinity. Inputs that used to abort
the process (allocation failure) or to run for hours run in a child process with a
memory limit and a timeout, so that a regression fails one test instead of killing or
stalling pytest.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

F64_MAX = float(np.finfo(np.float64).max)
F64_TINY = 5e-324  # the smallest subnormal
BOX = ([0.0, 0.0, 0.0], np.eye(3), [0.5, 0.5, 0.5])

# Address space a child may add after its imports: far above what any call here needs
# and far below the gigabytes the old up-front allocations asked for, so a regression
# aborts on every machine instead of succeeding where memory happens to be plentiful.
CHILD_HEADROOM = 1 << 30
# Only a hang detector: every call below returns in a few seconds at most.
CHILD_TIMEOUT_S = 120


def run_isolated(expression: str, headroom: int = CHILD_HEADROOM) -> str:
    """Evaluate ``expression`` (with ``np`` and ``cbfgen`` imported) in a child Python
    whose address space may grow by ``headroom`` bytes, and return what it ended with:
    ``"CbfError: <message>"`` or ``"returned: <repr>"``. A panic, an abort or a hang
    fails the calling test with the child's stderr."""
    program = textwrap.dedent(f"""
        import resource
        import numpy as np
        import cbfgen
        size = int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (size + {headroom}, size + {headroom}))
        try:
            result = {expression}
        except cbfgen.CbfError as e:
            print("CbfError:", e)
        else:
            print("returned:", repr(result)[:200])
    """)
    try:
        child = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                               timeout=CHILD_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{expression} did not return within {CHILD_TIMEOUT_S} s (hang)")
    if child.returncode != 0:
        pytest.fail(f"{expression} ended the child with exit status {child.returncode}:\n{child.stderr[-2000:]}")
    return child.stdout.strip()


def assert_finite(*arrays) -> None:
    for a in arrays:
        assert np.all(np.isfinite(np.asarray(a, dtype=float))), a


# ---------------------------------------------------------------- capacities
@pytest.mark.parametrize("expression, message", [
    # Each of these asked for gigabytes up front (or wrapped the row count first) and
    # aborted the process.
    ("cbfgen.Environment(edges=10**9)", "body_edge capacity = 1000000000 is above the maximum"),
    ("cbfgen.EcbfFilter(edges=2**64 // 7 + 1)", "body_edge capacity = 2635249153387078803 is above the maximum"),
    ("cbfgen.EcbfFilter(edges=10**6)", "body_edge capacity = 1000000 is above the maximum"),
    # Capacity overflow panics.
    ("cbfgen.Environment(edges=2**62)", "body_edge capacity = 4611686018427387904 is above the maximum"),
    ("cbfgen.EcbfFilter(foothold_edges=[2**62] * 6)", "foothold capacity = 4611686018427387904 is above"),
])
def test_absurd_capacities_raise_instead_of_aborting(expression, message):
    assert run_isolated(expression).startswith(f"CbfError: {message}")


def test_capacities_up_to_the_documented_maximum_are_accepted():
    env = cbfgen.Environment(edges=cbfgen.MAX_EDGES, foothold_edges=[cbfgen.MAX_FOOTHOLD_EDGES] * 6)
    assert env.capacity == (cbfgen.MAX_EDGES, [cbfgen.MAX_FOOTHOLD_EDGES] * 6)
    with pytest.raises(cbfgen.CbfError, match="above the maximum"):
        cbfgen.Environment(edges=cbfgen.MAX_EDGES + 1)
    with pytest.raises(cbfgen.CbfError, match="above the maximum"):
        cbfgen.EcbfFilter(foothold_edges=[1, 1, 1, 1, 1, cbfgen.MAX_FOOTHOLD_EDGES + 1])


@pytest.mark.parametrize("call", [
    lambda: cbfgen.Environment(edges=-1),
    lambda: cbfgen.Environment(edges=2**64),
    lambda: cbfgen.EcbfFilter(foothold_edges=[-1] * 6),
    lambda: cbfgen.EcbfFilter(max_iter=-1),
    lambda: cbfgen.EcbfFilter(max_iter=2**32),
])
def test_counts_outside_their_integer_type_raise_overflow_error(call):
    with pytest.raises(OverflowError):
        call()


def test_more_foothold_edges_than_the_capacity_raise():
    env = cbfgen.Environment(foothold_edges=[2] * 6)
    normals = np.tile([1.0, 0.0], (3, 1))
    with pytest.raises(cbfgen.CbfError, match="too many foothold edges: capacity is 2"):
        env.set_foothold(0, normals, np.zeros(3))
    env.set_foothold(0, normals[:2], np.zeros(2))
    assert env.foothold(0)[0].shape == (2, 2)


# ---------------------------------------------------------- solver settings
@pytest.mark.parametrize("time_limit_us", [1e26, F64_MAX, np.inf, np.nan, 0.0, -1.0, 2e6])
def test_a_time_limit_outside_the_domain_raises(time_limit_us):
    # 1e26 µs used to panic in Duration::from_secs_f64; a 1 kHz filter has no use for
    # a limit of seconds.
    with pytest.raises(cbfgen.CbfError, match="time_limit_us"):
        cbfgen.EcbfFilter(time_limit_us=time_limit_us)


def test_time_limits_up_to_the_documented_maximum_are_accepted():
    for us in (F64_TINY * 1e6, 1e-3, 500.0, cbfgen.MAX_TIME_LIMIT_US):
        safety = cbfgen.EcbfFilter(time_limit_us=us)
        assert_finite(safety.update(cbfgen.standard_posture(), np.zeros(cbfgen.NU), cbfgen.Environment()).u)


@pytest.mark.parametrize("settings, name", [
    # Together these ran one update() for hours while holding the GIL; each one alone
    # is outside the solver's documented domain.
    ({"max_iter": 2**32 - 1, "eps_abs": F64_TINY, "eps_rel": F64_TINY}, "max_iter|eps_abs|eps_rel"),
    ({"max_iter": 2**32 - 1}, "max_iter"),
    ({"eps_abs": F64_TINY}, "eps_abs"),
    ({"eps_rel": F64_TINY}, "eps_rel"),
])
def test_solver_settings_that_could_hang_an_update_raise(settings, name):
    with pytest.raises(cbfgen.CbfError, match=name):
        cbfgen.EcbfFilter(**settings)


def test_the_slowest_accepted_solver_settings_end_an_update():
    # The most iterations at the tightest tolerances: an update still ends (in
    # milliseconds), and the child's timeout catches a regression to hours.
    expression = ("cbfgen.EcbfFilter(max_iter=cbfgen.MAX_ITERATIONS, eps_abs=1e-12, eps_rel=1e-12)"
                  ".update(cbfgen.Course('step').initial_state(), np.ones(cbfgen.NU), cbfgen.Environment()).source")
    assert run_isolated(expression).startswith("returned: ")


# ---------------------------------------------------------------- simulation
@pytest.mark.parametrize("max_time", ["1e300", "1e4", "cbfgen.MAX_SIM_TIME * (1 + 1e-15)", "float('inf')", "0.0",
                                      "-1.0"])
def test_a_simulation_length_outside_the_domain_raises(max_time):
    # 1e300 s used to panic (capacity overflow) reserving a sample per cycle.
    assert run_isolated(f"cbfgen.simulate('step', max_time={max_time})").startswith("CbfError: max_time")


def test_the_longest_simulation_does_not_reserve_memory_up_front():
    # max_time used to reserve a sample per cycle before the first one: 6e5 samples of
    # over 300 bytes at MAX_SIM_TIME. The step course completes after about 16 s, so a
    # run that only grows with its cycles needs a few MB, far below this headroom.
    outcome = run_isolated("cbfgen.simulate('step', max_time=cbfgen.MAX_SIM_TIME)['summary']['completed']",
                           headroom=100 << 20)
    assert outcome == "returned: True"


# ------------------------------------------------------------ filter inputs
def course_states(count: int, seed: int):
    """States scattered around the step scenario's start with the course's nominal input
    and environment: the conditions the fuzz run found NaN outputs in."""
    course = cbfgen.Course("step")
    x0 = course.initial_state()
    rng = np.random.default_rng(seed)
    for _ in range(count):
        x = x0 + rng.normal(0.0, 0.02, cbfgen.NX)
        yield x, course.plan(0.0, x), course.environment


@pytest.mark.parametrize("value", [F64_MAX, -F64_MAX, 1e300])
@pytest.mark.parametrize("column", [0, 3, 4, 16])
def test_a_huge_nominal_input_raises_and_leaves_the_filter_usable(column, value):
    # One entry of f64::MAX made update() return an all-NaN u labelled "qp".
    safety = cbfgen.EcbfFilter()
    x, env = cbfgen.standard_posture(), cbfgen.Environment()
    u_ref = np.zeros(cbfgen.NU)
    u_ref[column] = value
    with pytest.raises(cbfgen.CbfError, match="u_ref|input"):
        safety.update(x, u_ref, env)
    for x, u_ref, env in course_states(20, seed=column):
        out = safety.update(x, u_ref, env)
        assert_finite(out.u)


def test_input_limits_beyond_the_domain_raise():
    # input_min = input_max = 1e307 used to be accepted and give NaN labelled "qp".
    with pytest.raises(cbfgen.CbfError, match="input limit"):
        cbfgen.EcbfFilter(input_min=[1e307] * cbfgen.NU, input_max=[1e307] * cbfgen.NU)


@pytest.mark.parametrize("limit", [cbfgen.MAX_INPUT, -cbfgen.MAX_INPUT, 0.0])
def test_a_degenerate_input_box_inside_the_domain_never_yields_a_non_finite_input(limit):
    safety = cbfgen.EcbfFilter(input_min=[limit] * cbfgen.NU, input_max=[limit] * cbfgen.NU)
    for x, u_ref, env in course_states(200, seed=1):
        out = safety.update(x, u_ref, env)
        assert np.all(np.isfinite(out.u)), (out, out.u)


def toe_at_hip() -> np.ndarray:
    """The standard posture with toe LF exactly at its hip: the knee length is 0 and
    the joint-limit rows' derivatives divide by it."""
    x = cbfgen.standard_posture()
    lf = 12  # lf_x, lf_z follow at 12, 13 (origin frame)
    x[lf] = x[cbfgen.STATE_NAMES.index("bx")] + 0.4  # HIP_POSITIONS[LF] = (0.4, 0.4, 0.12)
    x[lf + 1] = x[cbfgen.STATE_NAMES.index("bz")] + 0.12
    return x


def test_a_toe_at_its_hip_raises_in_the_row_functions():
    with pytest.raises(cbfgen.CbfError, match="not finite"):
        cbfgen.joint_limits("LF", toe_at_hip())


def test_a_toe_at_its_hip_gives_the_filter_a_finite_fallback():
    safety = cbfgen.EcbfFilter()
    out = safety.update(toe_at_hip(), np.zeros(cbfgen.NU), cbfgen.Environment())
    assert_finite(out.u)
    assert out.source != "qp" and out.nonfinite_row is not None


# ------------------------------------------------------------------ kernels
KERNELS = {
    "joint_limits": lambda x: cbfgen.joint_limits(0, x),
    "foot_height": lambda x: cbfgen.foot_height(1, x, 0.0),
    "stability": lambda x: cbfgen.stability(2, x, 1.0, 0.4),
    "body_edge": lambda x: cbfgen.body_edge(x, *BOX),
    "toe_edge": lambda x: cbfgen.toe_edge(3, x, *BOX),
    "foothold": lambda x: cbfgen.foothold(4, x, [1.0, 0.0], 0.5),
    "dynamics_f": cbfgen.dynamics_f,
    "dynamics_g": cbfgen.dynamics_g,
    "xdot": lambda x: cbfgen.xdot(x, np.ones(cbfgen.NU)),
    "world_kinematics": cbfgen.world_kinematics,
    "course_plan": lambda x: cbfgen.Course("step").plan(0.0, x),
    "course_clearance": lambda x: cbfgen.Course("step").clearance(x),
}


@pytest.mark.parametrize("state", [cbfgen.standard_posture() * 1e300, np.full(cbfgen.NX, F64_MAX),
                                   np.full(cbfgen.NX, -1e200), cbfgen.standard_posture() + 2e6])
@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_states_beyond_the_domain_raise(kernel, state):
    # Such states used to give NaN or inf rows without an error.
    with pytest.raises(cbfgen.CbfError, match="state entry"):
        KERNELS[kernel](state)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_states_at_the_edge_of_the_domain_give_finite_values_or_raise(kernel, seed):
    # Entries of magnitude STATE_LIMIT: finite values, or a CbfError (a row that is not
    # finite at singular geometry; a box derived from the state beyond the box domain),
    # never NaN handed back.
    rng = np.random.default_rng(seed)
    x = rng.choice([-1.0, 1.0], cbfgen.NX) * cbfgen.STATE_LIMIT * rng.choice([1.0, 1e-3, 1e-6], cbfgen.NX)
    try:
        result = KERNELS[kernel](x)
    except cbfgen.CbfError:
        return
    assert_finite(*(result if isinstance(result, tuple) else (result,)))


SSAT_BOXES = (*BOX, [1.5, 0.2, 0.1], np.eye(3), [0.5, 0.5, 0.5])


@pytest.mark.parametrize("alpha", [F64_TINY, 1e-300, 1e-12, 1e12, 1e300, F64_MAX])
@pytest.mark.parametrize("function", ["ssat", "ssat_derivatives", "ssat_margin"])
def test_ssat_smoothing_beyond_the_domain_raises(function, alpha):
    # Such alphas used to give inf or NaN without an error.
    args = SSAT_BOXES if function != "ssat_margin" else (SSAT_BOXES[2], SSAT_BOXES[5])
    for smoothing in ({"alpha": alpha}, {"alpha_rot": alpha}):
        with pytest.raises(cbfgen.CbfError, match="alpha"):
            getattr(cbfgen, function)(*args, **smoothing)


@pytest.mark.parametrize("alpha", cbfgen.SSAT_ALPHA_RANGE)
@pytest.mark.parametrize("variant", cbfgen.SSAT_VARIANTS)
def test_ssat_at_the_edges_of_its_domain_is_finite(variant, alpha):
    lo, hi = cbfgen.HALF_EXTENT_RANGE
    smoothing = {"alpha": alpha, "alpha_rot": alpha, "variant": variant}
    for half_b in ([0.5, 0.5, 0.5], [lo, lo, lo], [hi, hi, hi]):
        for p_b in ([1.5, 0.2, 0.1], [cbfgen.MAX_COORDINATE] * 3, [-cbfgen.MAX_COORDINATE, 0.0, 0.0]):
            boxes = (*BOX, p_b, np.eye(3), half_b)
            assert_finite(cbfgen.ssat(*boxes, **smoothing), *cbfgen.ssat_derivatives(*boxes, **smoothing),
                          cbfgen.ssat_margin(BOX[2], half_b, **smoothing))


def test_boxes_beyond_the_domain_raise():
    lo, hi = cbfgen.HALF_EXTENT_RANGE
    for p_b, half_b, message in [([cbfgen.MAX_COORDINATE * 1.01, 0, 0], [0.5] * 3, "centre"),
                                 ([1.5, 0, 0], [lo / 2] * 3, "half extent"),
                                 ([1.5, 0, 0], [hi * 2] * 3, "half extent")]:
        with pytest.raises(cbfgen.CbfError, match=message):
            cbfgen.ssat(*BOX, p_b, np.eye(3), half_b)


# ------------------------------------------------------------ arrays in
@pytest.mark.parametrize("call", [
    lambda c: cbfgen.dynamics_f(cbfgen.standard_posture() + c),
    lambda c: cbfgen.xdot(cbfgen.standard_posture(), np.zeros(cbfgen.NU) + c),
    lambda c: cbfgen.ssat(BOX[0], np.eye(3) + c, *BOX[2:], *BOX),
    lambda c: cbfgen.EcbfFilter(input_min=-np.ones(cbfgen.NU) + c),
    lambda c: cbfgen.EcbfFilter().update(cbfgen.standard_posture(), np.zeros(cbfgen.NU) + c, cbfgen.Environment()),
    lambda c: cbfgen.Environment().set_foothold(0, np.array([[1.0, 0.0]]) + c, [0.5]),
])
@pytest.mark.parametrize("imaginary", [0j, 1j])
def test_complex_arrays_are_refused(call, imaginary):
    # numpy's cast to float64 drops the imaginary part: even 0j is refused, by dtype.
    with pytest.raises(ValueError, match="complex128"):
        call(imaginary)


@pytest.mark.parametrize("values", [["0.1"] * cbfgen.NU, [None] * cbfgen.NU, [object()] * cbfgen.NU])
def test_strings_and_objects_are_refused(values):
    with pytest.raises(ValueError, match="expected real numbers"):
        cbfgen.xdot(cbfgen.standard_posture(), values)


@pytest.mark.parametrize("dtype", [np.float32, np.int64, np.uint8, np.bool_, np.longdouble, ">f8"])
def test_real_arrays_of_any_dtype_are_read_as_float64(dtype):
    x = cbfgen.standard_posture()
    u = np.ones(cbfgen.NU)
    np.testing.assert_array_equal(cbfgen.xdot(x, u.astype(dtype)), cbfgen.xdot(x, u))


def test_foothold_normals_must_be_k_by_2():
    env = cbfgen.Environment()
    # A (2, 3) array used to be read as three 2-vectors.
    with pytest.raises(ValueError, match=r"expected shape \(k, 2\), got shape \(2, 3\)"):
        env.set_foothold(0, np.ones((2, 3)), [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=r"got shape \(4,\)"):
        env.set_foothold(0, [1.0, 0.0, 0.0, 1.0], [0.1, 0.2])
    with pytest.raises(ValueError, match=r"offsets|shape \(k,\)"):
        env.set_foothold(0, [[1.0, 0.0], [0.0, 1.0]], [[0.1], [0.2]])
    env.set_foothold(0, [[1.0, 0.0], [0.0, 1.0]], [0.1, 0.2])
    env.set_foothold(0, [], [])  # no polygon
    assert env.foothold(0)[0].shape == (0, 2)


def test_rotations_are_9_values_or_3_by_3():
    yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    as_matrix = cbfgen.ssat(BOX[0], yaw, [0.5, 0.2, 0.1], [1.0, 0.3, 0.0], np.eye(3), [0.5, 0.5, 0.5])
    as_values = cbfgen.ssat(BOX[0], yaw.ravel(), [0.5, 0.2, 0.1], [1.0, 0.3, 0.0], np.eye(3), [0.5, 0.5, 0.5])
    assert as_matrix == as_values
    # A Fortran-ordered 3x3 is still read row by row.
    assert as_matrix == cbfgen.ssat(BOX[0], np.asfortranarray(yaw), [0.5, 0.2, 0.1], [1.0, 0.3, 0.0],
                                    np.eye(3), [0.5, 0.5, 0.5])
    for shape in [(1, 9), (9, 1), (3, 3, 1)]:
        with pytest.raises(ValueError, match="9 row-major values"):
            cbfgen.ssat(BOX[0], np.eye(3).reshape(shape), *BOX[2:], *BOX)


@pytest.mark.parametrize("shape", [(6, 6), (1, 36), (36, 1)])
def test_vectors_must_be_one_dimensional(shape):
    with pytest.raises(ValueError, match=r"expected 36 values in shape \(36,\)"):
        cbfgen.dynamics_f(cbfgen.standard_posture().reshape(shape))


def test_a_reflection_is_reported_by_its_determinant():
    # It used to say "deviation 0.000e0", which read as if the matrix were fine.
    with pytest.raises(cbfgen.CbfError, match=r"det R = -1\.0"):
        cbfgen.ssat(BOX[0], np.diag([1.0, 1.0, -1.0]), *BOX[2:], *BOX)


def test_course_outputs_are_finite_or_raise():
    course = cbfgen.Course("step")
    for gap in (F64_MAX, -F64_MAX):
        assert_finite(course.initial_state(start_gap=gap))
    x = course.initial_state()
    for t in (0.0, 1e300, F64_MAX, -1e300):
        try:
            assert_finite(course.plan(t, x))
        except cbfgen.CbfError:
            pass
