"""Issue 12's fuzz findings that reach Python, as regression tests, over the generic API
(``System``, ``Params``, ``EcbfFilter``, ``Rows``, ``call_kernel``) of every built-in
system, and Tachyon 3's own helpers (``cbfgen.tachyon3``).

Each bad input must raise a typed exception (``cbfgen.CbfError``, ``ValueError``,
``OverflowError``), never ``PanicException``, and must leave the process alive, the
parameters as they were and the filter usable; no call may hand back a NaN or an
infinity. Inputs that used to abort the process (allocation failure) or to run for hours
run in a child process with a memory limit and a timeout, so that a regression fails one
test instead of killing or stalling pytest.

"""

from __future__ import annotations

import inspect
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

from cbfgen import tachyon3 as t3  # noqa: E402  (after the skip above)

F64_MAX = float(np.finfo(np.float64).max)
F64_TINY = 5e-324  # the smallest subnormal
BOX = ([0.0, 0.0, 0.0], np.eye(3), [0.5, 0.5, 0.5])
SYSTEMS = cbfgen.systems()
T3 = t3.SYSTEM
DI = cbfgen.System("double_integrator")

# Address space a child may add after its imports: far above what any call here needs
# and far below the gigabytes the old up-front allocations asked for, so a regression
# aborts on every machine instead of succeeding where memory happens to be plentiful.
CHILD_HEADROOM = 1 << 30
# Only a hang detector: every call below returns in a few seconds at most.
CHILD_TIMEOUT_S = 120


def run_isolated(expression: str, headroom: int = CHILD_HEADROOM) -> str:
    """Evaluate ``expression`` (with ``np``, ``cbfgen`` and ``t3`` = ``cbfgen.tachyon3``
    imported) in a child Python whose address space may grow by ``headroom`` bytes, and
    return what it ended with: ``"CbfError: <message>"`` or ``"returned: <repr>"``. A
    panic, an abort or a hang fails the calling test with the child's stderr."""
    program = textwrap.dedent(f"""
        import resource
        import numpy as np
        import cbfgen
        from cbfgen import tachyon3 as t3
        {{READY}}
        size = int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (size + {headroom}, size + {headroom}))
        try:
            result = {expression}
        except cbfgen.CbfError as e:
            print("CbfError:", e)
        else:
            print("returned:", repr(result)[:200])
    """).replace("{READY}\n", READY_SOURCE)
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


def nominal_state(system: cbfgen.System) -> np.ndarray:
    """A state inside every row's domain: Tachyon 3's standard posture, or near zero."""
    if system.name == "tachyon3":
        return t3.standard_posture()
    return np.linspace(0.1, -0.2, system.nx)


def family(system: cbfgen.System, name: str) -> dict:
    return next(f for f in system.families if f["name"] == name)


def sample_values(f: dict, scale: float = 0.25) -> dict:
    """Valid values for one instance of family ``f``, inside each parameter's domain:
    ``scale`` everywhere (``lo + scale`` for an interval), square matrices (rotations)
    the identity, unit vectors turned by ``scale`` radians from the first axis."""
    out = {}
    for name, shape in f["params"]:
        kind, *bounds = f["domains"][name]
        if len(shape) == 2 and shape[0] == shape[1]:
            out[name] = np.eye(shape[0])
        elif kind == "unit_vector":
            out[name] = np.zeros(shape)
            out[name][:2] = [np.cos(scale), np.sin(scale)]
        else:
            value = bounds[0] + scale if kind == "interval" else scale
            out[name] = np.full(shape, value) if shape else value
    return out


def ready_params(system: cbfgen.System, counts: dict | None = None) -> cbfgen.Params:
    """``system.params(counts)`` with every fixed instance nobody set (its spec gives
    no default: the filter refuses it) set to sample values."""
    params = system.params(counts) if counts else system.params()
    for f in system.families:
        if f["instances"] != "fixed" or not f["params"]:
            continue
        for member in f["members"] or [None]:
            at = {} if member is None else {"member": member}
            for instance in range(f["count"]):
                try:
                    params.get(f["name"], instance=instance, **at)
                except cbfgen.CbfError as e:
                    assert "was never set" in str(e), e
                    params.set(f["name"], sample_values(f), instance=instance, **at)
    return params


# The two above, as source for the child processes of run_isolated (one definition).
READY_SOURCE = "\n".join(textwrap.dedent(inspect.getsource(f)) for f in (sample_values, ready_params))


def at_limit(f: dict) -> dict:
    """Each parameter at PARAM_LIMIT where its domain reaches it, else at its sample value."""
    reaches = {"real", "positive", "non_negative"}
    return {p: np.full(np.shape(v), cbfgen.PARAM_LIMIT) if f["domains"][p][0] in reaches else v
            for p, v in sample_values(f).items()}


def outside_its_domain(family_name: str, param: str) -> str:
    """The message of a value outside ``param``'s domain, whichever member and instance."""
    return f"^{family_name}( member \\w+)? instance \\d+: parameter {param} is outside its domain"


def flat(values: dict) -> np.ndarray:
    return np.concatenate([np.ravel(v) for v in values.values()])


def same(a: dict | None, b: dict | None) -> bool:
    if a is None or b is None:
        return a is b
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def capacity_of_every(system: cbfgen.System, count: int) -> dict:
    """Room for ``count`` instances of every capacity family, or as many as it accepts."""
    return {f["name"]: min(count, f["count"]) for f in system.families if f["instances"] == "capacity"}


def placed(system_name: str, family_name: str, count: int = 2):
    """``(params, family, keywords)``: parameters of ``system_name`` with room for
    ``count`` instances of every capacity family, one instance of ``family_name`` present
    (of its last member, for an indexed family), and the ``member=`` keyword that addresses
    it."""
    system = cbfgen.System(system_name)
    f = family(system, family_name)
    params = system.params(capacity_of_every(system, count))
    kw = {"member": f["members"][-1]} if f["members"] else {}
    if f["instances"] == "capacity":
        params.push(family_name, sample_values(f), **kw)
    else:
        params.set(family_name, sample_values(f), **kw)
    return params, f, kw


# Every (system, family) with parameters, and those whose members are indexed.
PARAM_FAMILIES = [(s, f["name"]) for s in SYSTEMS for f in cbfgen.System(s).families if f["params"]]
INDEXED_FAMILIES = [(s, f["name"]) for s in SYSTEMS for f in cbfgen.System(s).families if f["members"]]
CAPACITY_FAMILIES = [(s, f["name"]) for s in SYSTEMS for f in cbfgen.System(s).families
                     if f["instances"] == "capacity"]


def toe_at_hip() -> np.ndarray:
    """The standard posture with toe LF exactly at its hip: the knee length is 0 and
    the joint-limit rows' derivatives divide by it."""
    x = t3.standard_posture()
    lf = 12  # lf_x, lf_z follow at 12, 13 (origin frame)
    x[lf] = x[t3.STATE_NAMES.index("bx")] + 0.4  # HIP_POSITIONS[LF] = (0.4, 0.4, 0.12)
    x[lf + 1] = x[t3.STATE_NAMES.index("bz")] + 0.12
    return x


# ====================================================================== systems by name
@pytest.mark.parametrize("name", ["no_such_system", "", "TACHYON3", "tachyon3 ", "tachyon"])
def test_an_unknown_system_name_raises(name):
    with pytest.raises(cbfgen.CbfError, match="no system named"):
        cbfgen.System(name)
    with pytest.raises(cbfgen.CbfError, match="no system named"):
        cbfgen.EcbfFilter(name)


@pytest.mark.parametrize("system", [None, 3, b"tachyon3", ["tachyon3"]])
def test_a_system_that_is_no_name_raises_type_error(system):
    with pytest.raises(TypeError):
        cbfgen.EcbfFilter(system)


@pytest.mark.parametrize("name", SYSTEMS)
def test_every_system_by_name_and_by_object_is_the_same(name):
    by_name, by_object = cbfgen.EcbfFilter(name), cbfgen.EcbfFilter(cbfgen.System(name))
    assert by_name.system == by_object.system == name
    assert by_name.layout == by_object.layout == cbfgen.System(name).filter().layout


# ================================================================== capacities
@pytest.mark.parametrize("expression, message", [
    # Each of these asked for gigabytes up front (or wrapped the row count first) and
    # aborted the process.
    ("t3.Environment(edges=10**9)", "body_edge capacity = 1000000000 is above the maximum"),
    ("t3.ecbf_filter(edges=2**64 // 7 + 1)", "body_edge capacity = 2635249153387078803 is above the maximum"),
    ("t3.ecbf_filter(edges=10**6)", "body_edge capacity = 1000000 is above the maximum"),
    # Capacity overflow panics.
    ("t3.Environment(edges=2**62)", "body_edge capacity = 4611686018427387904 is above the maximum"),
    ("t3.ecbf_filter(foothold_edges=[2**62] * 6)", "foothold capacity = 4611686018427387904 is above"),
    # The same through the generic capacity dict.
    ("t3.SYSTEM.params({'body_edge': 10**9})", "body_edge capacity = 1000000000 is above the maximum"),
    ("cbfgen.EcbfFilter('tachyon3', {'toe_edge': 2**62})", "toe_edge capacity = 4611686018427387904 is above"),
    ("cbfgen.System('tachyon3').filter({'foothold': [0, 0, 0, 0, 0, 2**63]})",
     "foothold capacity = 9223372036854775808 is above"),
    ("cbfgen.EcbfFilter('tachyon3', {'body_edge': 2**64 - 1, 'toe_edge': 2**64 - 1, 'foothold': 2**64 - 1})",
     "body_edge capacity = 18446744073709551615 is above"),
])
def test_absurd_capacities_raise_instead_of_aborting(expression, message):
    assert run_isolated(expression).startswith(f"CbfError: {message}")


def test_capacities_up_to_the_documented_maximum_are_accepted():
    assert family(T3, "body_edge")["count"] == family(T3, "toe_edge")["count"] == t3.MAX_EDGES
    assert family(T3, "foothold")["count"] == t3.MAX_FOOTHOLD_EDGES
    env = t3.Environment(edges=t3.MAX_EDGES, foothold_edges=[t3.MAX_FOOTHOLD_EDGES] * 6)
    assert env.sizes == (t3.MAX_EDGES, [t3.MAX_FOOTHOLD_EDGES] * 6)
    assert env.capacity == {**T3.params().capacity, **t3.capacity(t3.MAX_EDGES, [t3.MAX_FOOTHOLD_EDGES] * 6)}
    largest = T3.params({"body_edge": t3.MAX_EDGES, "toe_edge": t3.MAX_EDGES, "foothold": t3.MAX_FOOTHOLD_EDGES})
    assert largest.capacity == env.capacity
    with pytest.raises(cbfgen.CbfError, match="above the maximum"):
        t3.Environment(edges=t3.MAX_EDGES + 1)
    with pytest.raises(cbfgen.CbfError, match="above the maximum"):
        t3.ecbf_filter(foothold_edges=[1, 1, 1, 1, 1, t3.MAX_FOOTHOLD_EDGES + 1])
    with pytest.raises(cbfgen.CbfError, match="above the maximum"):
        T3.params({"toe_edge": t3.MAX_EDGES + 1})
    with pytest.raises(cbfgen.CbfError, match="above the maximum"):
        cbfgen.EcbfFilter(T3, {"foothold": [t3.MAX_FOOTHOLD_EDGES + 1, 0, 0, 0, 0, 0]})


@pytest.mark.parametrize("call", [
    lambda: t3.Environment(edges=-1),
    lambda: t3.Environment(edges=2**64),
    lambda: t3.Environment(foothold_edges=[-1] * 6),
    lambda: t3.ecbf_filter(max_iter=-1),
    lambda: t3.ecbf_filter(max_iter=2**32),
    lambda: cbfgen.EcbfFilter("double_integrator", max_iter=2**64),
    lambda: DI.params().set("sine_barrier", [0.0, 0.0, 0.0], instance=-1),
    lambda: DI.params().get("sine_barrier", instance=2**64),
    lambda: T3.params().remove("stability", member=0, instance=-1),
])
def test_counts_outside_their_integer_type_raise_overflow_error(call):
    with pytest.raises(OverflowError):
        call()


@pytest.mark.parametrize("counts", [{"body_edge": -1}, {"body_edge": 2**64}, {"foothold": 2**70}])
def test_generic_capacities_outside_a_count_raise_overflow_error(counts):
    # As every integer argument outside its type: OverflowError.
    with pytest.raises(OverflowError):
        T3.params(counts)
    with pytest.raises(OverflowError):
        cbfgen.EcbfFilter(T3, counts)


@pytest.mark.parametrize("counts", [
    {"body_edge": 1.5}, {"body_edge": "3"}, {"body_edge": None},
    {"foothold": "abcdef"}, {"foothold": [1, 2, 3, 4, 5, -6]},
])
def test_generic_capacities_that_are_no_counts_raise(counts):
    # A ValueError for anything that is neither a count nor a list of them.
    with pytest.raises(ValueError, match="a count or one count per member"):
        T3.params(counts)
    with pytest.raises(ValueError, match="a count or one count per member"):
        cbfgen.EcbfFilter(T3, counts)
    with pytest.raises(ValueError, match="a count or one count per member"):
        t3.ecbf_filter(foothold_edges=[-1] * 6)


@pytest.mark.parametrize("system, counts, message", [
    ("tachyon3", {"no_such_family": 1}, "no family named"),
    ("tachyon3", {"joint_limits": 1}, "not available for fixed-count families"),
    ("tachyon3", {"foot_height": 2}, "not available for fixed-count families"),
    ("tachyon3", {"stability": 3}, "not available for fixed-count families"),
    ("tachyon3", {"foothold": [1] * 5}, "expected length 6, got 5"),
    ("tachyon3", {"foothold": [1] * 7}, "expected length 6, got 7"),
    ("tachyon3", {"body_edge": [1, 1]}, "expected length 1, got 2"),
    ("double_integrator", {"sine_barrier": 2}, "not available for fixed-count families"),
    ("double_integrator", {"body_edge": 2}, "no family named"),
])
def test_a_capacity_for_a_family_without_one_raises(system, counts, message):
    with pytest.raises(cbfgen.CbfError, match=message):
        cbfgen.System(system).params(counts)
    with pytest.raises(cbfgen.CbfError, match=message):
        cbfgen.EcbfFilter(system, counts)


@pytest.mark.parametrize("counts", [{1: 2}, [("body_edge", 2)], "body_edge"])
def test_a_capacity_that_is_no_dict_of_names_raises_type_error(counts):
    with pytest.raises(TypeError):
        T3.params(counts)


def test_more_foothold_edges_than_the_capacity_raise():
    env = t3.Environment(foothold_edges=[2] * 6)
    normals = np.tile([1.0, 0.0], (3, 1))
    with pytest.raises(cbfgen.CbfError, match="too many foothold edges: capacity is 2"):
        env.set_foothold(0, normals, np.zeros(3))
    env.set_foothold(0, normals[:2], np.zeros(2))
    assert env.foothold(0)[0].shape == (2, 2)
    # The generic push is refused past the same capacity, leaving both half-planes.
    with pytest.raises(cbfgen.CbfError, match="capacity is 2"):
        env.push("foothold", {"normal": [0.0, 1.0], "offset": 0.5}, member="lf")
    assert env.count("foothold", member="lf") == 2
    assert env.foothold("LF")[0].shape == (2, 2)


@pytest.mark.parametrize("system, name", CAPACITY_FAMILIES)
def test_push_on_a_full_capacity_family_raises_and_keeps_its_instances(system, name):
    sys_ = cbfgen.System(system)
    f = family(sys_, name)
    params = sys_.params(capacity_of_every(sys_, 2))
    full = min(2, f["count"])  # a family may accept fewer (a table: one)
    kw = {"member": 0} if f["members"] else {}
    for k in range(full):
        params.push(name, sample_values(f, 0.1 * (k + 1)), **kw)
    kept = [params.get(name, instance=i, **kw) for i in range(full)]
    with pytest.raises(cbfgen.CbfError, match=f"capacity is {full}"):
        params.push(name, sample_values(f, 0.5), **kw)
    assert params.count(name, **kw) == full
    assert all(same(params.get(name, instance=i, **kw), kept[i]) for i in range(full))
    # A family sized 0 takes none.
    empty = sys_.params()
    with pytest.raises(cbfgen.CbfError, match="capacity is 0"):
        empty.push(name, sample_values(f), **kw)
    assert empty.count(name, **kw) == 0
    # After clear there is room again.
    params.clear(name, **kw)
    params.push(name, sample_values(f, 0.5), **kw)
    assert params.count(name, **kw) == 1


def test_push_edge_on_a_full_environment_raises_and_keeps_its_edges():
    env = t3.Environment(edges=1)
    env.push_edge(*BOX)
    with pytest.raises(cbfgen.CbfError, match="capacity is 1"):
        env.push_edge([1.0, 0.0, 0.0], np.eye(3), [0.2, 0.2, 0.2])
    assert env.edge_count == env.count("body_edge") == env.count("toe_edge") == 1
    assert np.array_equal(env.get("toe_edge")["center"], BOX[0])


# ============================================================ parameters by family name
@pytest.mark.parametrize("system", SYSTEMS)
def test_an_unknown_family_raises_in_every_params_method(system):
    params = cbfgen.System(system).params()
    for call in (lambda n: params.set(n, [0.0]), lambda n: params.push(n, [0.0]), lambda n: params.get(n),
                 lambda n: params.remove(n), lambda n: params.clear(n), lambda n: params.set_enabled(n, False),
                 lambda n: params.is_enabled(n), lambda n: params.count(n)):
        for name in ("no_such_family", "", "Body_Edge", "sine_barrier " if system != "tachyon3" else "toe_edge "):
            with pytest.raises(cbfgen.CbfError, match="no family named"):
                call(name)
    with pytest.raises(cbfgen.CbfError, match="no family named"):
        cbfgen.EcbfFilter(system, activation={"no_such_family": 1.0})


@pytest.mark.parametrize("system, name", PARAM_FAMILIES)
def test_set_with_a_field_missing_or_extra_raises_and_keeps_the_value(system, name):
    params, f, kw = placed(system, name)
    before = params.get(name, **kw)
    good = sample_values(f, 0.5)
    for missing in good:
        with pytest.raises(ValueError, match=f"missing parameter '{missing}'"):
            params.set(name, {k: v for k, v in good.items() if k != missing}, **kw)
    for extra in ("no_such_param", good and next(iter(good)).upper(), 0):
        with pytest.raises(ValueError, match="unknown parameter"):
            params.set(name, {**good, extra: 0.0}, **kw)
    with pytest.raises(ValueError, match="missing parameter"):
        params.set(name, {}, **kw)
    assert same(params.get(name, **kw), before)
    if f["instances"] == "capacity":
        count = params.count(name, **kw)
        with pytest.raises(ValueError, match="missing parameter"):
            params.push(name, {k: v for k, v in good.items() if k != f["params"][0][0]}, **kw)
        assert params.count(name, **kw) == count
    # The valid dict does change it.
    params.set(name, good, **kw)
    assert same(params.get(name, **kw), {k: np.asarray(v, dtype=float) if np.ndim(v) else v for k, v in good.items()})


def wrong_shapes(shape: list[int]) -> list[tuple]:
    """Shapes that are not ``shape`` (nor, for a matrix, its flat row-major form)."""
    if not shape:
        return [(1,), (1, 1), (2,)]
    if len(shape) == 1:
        (n,) = shape
        return [(n + 1,), (n - 1,), (1, n), (n, 1), ()]
    r, c = shape
    return [(r, c + 1), (r * c - 1,), (r * c + 1,), (1, r * c), (r * c, 1), (c + 1, r), ()]


@pytest.mark.parametrize("system, name", PARAM_FAMILIES)
def test_set_with_a_wrongly_shaped_value_raises_and_keeps_the_value(system, name):
    params, f, kw = placed(system, name)
    before = params.get(name, **kw)
    good = sample_values(f, 0.5)
    for param, shape in f["params"]:
        for bad in wrong_shapes(shape):
            with pytest.raises(ValueError, match=f"{param}: expected"):
                params.set(name, {**good, param: np.full(bad, 0.5)}, **kw)
    width = len(flat(good))
    for bad in (width - 1, width + 1, 0):
        with pytest.raises(ValueError, match=f"{name}: expected shape \\({width},\\)"):
            params.set(name, np.full(bad, 0.5), **kw)
    for bad in [(1, width), (width, 1)]:
        with pytest.raises(ValueError, match=f"{name}: expected shape"):
            params.set(name, np.full(bad, 0.5), **kw)
    assert same(params.get(name, **kw), before)
    # The flat vector of the right width is the dict's values in declaration order.
    params.set(name, flat(good), **kw)
    by_flat = params.get(name, **kw)
    params.set(name, sample_values(f, 0.1), **kw)
    params.set(name, good, **kw)
    assert same(params.get(name, **kw), by_flat)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf, 1e300, -F64_MAX, cbfgen.PARAM_LIMIT * (1 + 1e-15)])
@pytest.mark.parametrize("system, name", PARAM_FAMILIES)
def test_set_or_push_with_a_value_outside_the_domain_raises_and_keeps_the_value(system, name, value):
    params, f, kw = placed(system, name)
    before, count = params.get(name, **kw), params.count(name, **kw)
    for param, _ in f["params"]:
        bad = sample_values(f)
        bad[param] = np.where(np.ones_like(bad[param], dtype=bool), value, bad[param])
        with pytest.raises(cbfgen.CbfError, match=outside_its_domain(name, param)):
            params.set(name, bad, **kw)
        values = flat(bad)
        with pytest.raises(cbfgen.CbfError, match=outside_its_domain(name, param)):
            params.set(name, values, **kw)
        if f["instances"] == "capacity" and count < f["count"]:  # room left: the domain refuses it
            with pytest.raises(cbfgen.CbfError, match=outside_its_domain(name, param)):
                params.push(name, values, **kw)
    assert same(params.get(name, **kw), before)
    assert params.count(name, **kw) == count
    # PARAM_LIMIT itself is inside (where the parameter's own domain reaches it).
    params.set(name, at_limit(f), **kw)


@pytest.mark.parametrize("system, name", PARAM_FAMILIES)
def test_set_with_values_that_are_not_real_numbers_raises_and_keeps_the_value(system, name):
    params, f, kw = placed(system, name)
    before = params.get(name, **kw)
    good = sample_values(f)
    width = len(flat(good))
    for bad in (flat(good) + 0j, [str(v) for v in flat(good)], [None] * width, None, "0.5"):
        with pytest.raises(ValueError, match="expected real numbers|expected shape"):
            params.set(name, bad, **kw)
    for param, _ in f["params"]:
        for bad in (np.asarray(good[param]) + 1j, "0.5", None, [object()]):
            with pytest.raises(ValueError, match="expected real numbers|expected"):
                params.set(name, {**good, param: bad}, **kw)
    assert same(params.get(name, **kw), before)


@pytest.mark.parametrize("system, name", INDEXED_FAMILIES)
def test_a_member_of_an_indexed_family_must_be_given_and_exist(system, name):
    params = cbfgen.System(system).params(capacity_of_every(cbfgen.System(system), 2))
    f = family(cbfgen.System(system), name)
    values = sample_values(f)
    one_member = [lambda **kw: params.set(name, values, **kw), lambda **kw: params.push(name, values, **kw),
                  lambda **kw: params.get(name, **kw), lambda **kw: params.remove(name, **kw),
                  lambda **kw: params.count(name, **kw), lambda **kw: params.is_enabled(name, **kw)]
    for call in one_member:
        with pytest.raises(ValueError, match="pass member="):
            call()
        for member in ("xx", "", f["members"][0] + "x", "body"):
            with pytest.raises(ValueError, match=f"has no member '{member}'"):
                call(member=member)
        for member in (len(f["members"]), -1, 10**9):
            with pytest.raises(ValueError, match=f"has members 0..{len(f['members'])}"):
                call(member=member)
        for member in (1.0, [0], 2**70):
            with pytest.raises(TypeError):
                call(member=member)
    # A member by index and by name in any case are the same one.
    if f["params"]:
        if f["instances"] == "capacity":
            params.push(name, sample_values(f, 0.75), member=f["members"][1].upper())
        else:
            params.set(name, sample_values(f, 0.75), member=f["members"][1].upper())
        assert same(params.get(name, member=1), params.get(name, member=f["members"][1]))
        assert not same(params.get(name, member=0), params.get(name, member=1))


@pytest.mark.parametrize("system, name", [(s, f["name"]) for s in SYSTEMS for f in cbfgen.System(s).families
                                          if not f["members"] and f["params"]])
def test_a_member_of_a_family_that_has_none_raises(system, name):
    params = cbfgen.System(system).params()
    for member in ("lf", "x", 1, -1):
        with pytest.raises(ValueError, match="has no member|has members 0..1"):
            params.count(name, member=member)
    params.count(name, member=0)  # the only one


@pytest.mark.parametrize("system, name", [(s, f["name"]) for s in SYSTEMS for f in cbfgen.System(s).families
                                          if not f["params"]])
def test_a_parameter_free_family_has_no_instances_to_reach(system, name):
    params = cbfgen.System(system).params()
    members = next(f["members"] for f in cbfgen.System(system).families if f["name"] == name)
    with pytest.raises(cbfgen.CbfError, match="parameter-free"):
        params.count(name, member=members[0] if members else None)


@pytest.mark.parametrize("system, name", PARAM_FAMILIES)
def test_an_instance_that_is_not_there_raises(system, name):
    params, f, kw = placed(system, name)
    slots = params.capacity[name] if not f["members"] else params.capacity[name][-1]
    for instance in (slots, slots + 1, 10**9):
        with pytest.raises(cbfgen.CbfError, match=f"no instance {instance}"):
            params.get(name, instance=instance, **kw)
        with pytest.raises(cbfgen.CbfError, match=f"no instance {instance}"):
            params.set(name, sample_values(f), instance=instance, **kw)
    if f["instances"] == "capacity" and slots > 1:  # slots past the ones pushed: set refuses, get says empty
        with pytest.raises(cbfgen.CbfError, match="no instance 1"):
            params.set(name, sample_values(f), instance=1, **kw)
        assert params.get(name, instance=1, **kw) is None


@pytest.mark.parametrize("system, name", [(s, f["name"]) for s in SYSTEMS for f in cbfgen.System(s).families])
def test_operations_a_family_does_not_support_raise_and_change_nothing(system, name):
    sys_ = cbfgen.System(system)
    f = family(sys_, name)
    params = sys_.params(capacity_of_every(sys_, 2))
    kw = {"member": 0} if f["members"] else {}
    snapshot = params.copy()
    refused = {
        "fixed": ["push", "remove", "clear", "set_enabled"],
        "optional": ["push", "set_enabled"],
        "capacity": ["remove"],
    }[f["instances"]]
    if not f["params"]:  # a parameter-free family has no values to access at all
        refused = ["set", "push", "get", "remove", "clear", "set_enabled"]
    calls = {"set": lambda: params.set(name, sample_values(f), **kw),
             "push": lambda: params.push(name, sample_values(f), **kw),
             "get": lambda: params.get(name, **kw), "remove": lambda: params.remove(name, **kw),
             "clear": lambda: params.clear(name, **kw), "set_enabled": lambda: params.set_enabled(name, False, **kw)}
    for op in refused:
        with pytest.raises(cbfgen.CbfError, match="not available"):
            calls[op]()
    assert params.capacity == snapshot.capacity
    for g in sys_.families:
        if g["params"]:
            for m in range(max(len(g["members"]), 1)):
                mkw = {"member": m} if g["members"] else {}
                assert params.count(g["name"], **mkw) == snapshot.count(g["name"], **mkw)
                assert params.is_enabled(g["name"], **mkw)


@pytest.mark.parametrize("system, name", PARAM_FAMILIES)
def test_a_copy_is_independent(system, name):
    params, f, kw = placed(system, name)
    before = params.get(name, **kw)
    copy = params.copy()
    assert copy.system == params.system and copy.capacity == params.capacity
    copy.set(name, sample_values(f, 0.75), **kw)
    assert same(params.get(name, **kw), before)
    assert not same(copy.get(name, **kw), before)


@pytest.mark.parametrize("dtype", [np.float32, np.int64, np.uint8, np.bool_, np.longdouble, ">f8"])
def test_parameters_of_any_real_dtype_are_read_as_float64(dtype):
    params = DI.params()
    params.set("sine_barrier", np.array([1, 1, 0]).astype(dtype))
    assert params.get("sine_barrier") == {"amplitude": 1.0, "omega": 1.0, "offset": 0.0}
    env = t3.Environment(edges=1)
    env.push("body_edge", {"center": np.array([1, 0, 0], dtype=dtype), "rotation": np.eye(3, dtype=dtype),
                           "half": np.array([1, 1, 1], dtype=dtype)})
    assert np.array_equal(env.get("body_edge")["rotation"], np.eye(3))


def test_a_rotation_parameter_is_9_values_or_3_by_3_read_row_by_row():
    yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    env = t3.Environment(edges=3)
    for rotation in (yaw, yaw.ravel(), np.asfortranarray(yaw)):
        env.push("toe_edge", {"center": [1.0, 0.0, 0.0], "rotation": rotation, "half": [0.5, 0.2, 0.1]})
    for i in range(3):
        assert np.array_equal(env.get("toe_edge", instance=i)["rotation"], yaw)
    for shape in [(1, 9), (9, 1), (3, 3, 1), (3, 1, 3)]:
        expected = r"rotation: expected shape \(3, 3\) or its 9 values row by row, shape \(9,\)"
        with pytest.raises(ValueError, match=expected):
            env.set("toe_edge", {"center": [0.0] * 3, "rotation": np.eye(3).reshape(shape), "half": [0.5] * 3})
    assert env.count("toe_edge") == 3


# ============================================================== parameters across systems
@pytest.mark.parametrize("own, other", [(a, b) for a in SYSTEMS for b in SYSTEMS if a != b])
def test_params_of_another_system_raise_and_leave_the_filter_usable(own, other):
    system = cbfgen.System(own)
    safety = system.filter()
    x, u_ref, params = nominal_state(system), np.zeros(system.nu), ready_params(system)
    first = safety.update(x, u_ref, params)
    foreign = cbfgen.System(other).params()
    with pytest.raises(cbfgen.CbfError, match=f"parameters of system {other} given to system {own}"):
        safety.update(x, u_ref, foreign)
    with pytest.raises(cbfgen.CbfError, match=f"parameters of system {other} given to system {own}"):
        system.rows(x, foreign)
    # The filter is unchanged, and the next cycle with its own parameters is fine.
    assert np.array_equal(safety.output.u, first.u) and safety.output.source == first.source
    out = safety.update(x, u_ref, params)
    assert_finite(out.u)
    assert out.source == "qp"


def test_params_of_another_capacity_raise_and_leave_the_filter_usable():
    safety = t3.ecbf_filter()
    x, u_ref = t3.standard_posture(), np.zeros(t3.NU)
    for wrong in (t3.Environment(edges=3), T3.params(), T3.params({**t3.capacity(), "foothold": 15})):
        with pytest.raises(cbfgen.CbfError, match="other capacities than the filter"):
            safety.update(x, u_ref, wrong)
        assert_finite(safety.update(x, u_ref, t3.Environment()).u)
    # Parameters of the same capacity are accepted whichever way they were built.
    for same_size in (T3.params(t3.capacity()), t3.Environment().copy(), t3.Course("step").environment):
        assert safety.update(x, u_ref, same_size).source == "qp"


def test_a_filter_built_from_params_or_from_its_first_params_cannot_disagree_with_them():
    x, u_ref = t3.standard_posture(), np.zeros(t3.NU)
    capacity = {**t3.capacity(), "foothold": 15}
    params = T3.params(capacity)
    rows = len(T3.rows(x, params))
    # The capacities a Params reports are ones params() and filter() take (a fixed or
    # optional family's own count among them), and another count for those is refused.
    assert {"body_edge", "toe_edge", "foothold", "foot_height"} <= set(params.capacity)
    assert T3.filter(capacity=params.capacity).row_count == rows
    assert T3.params(params.capacity).capacity == params.capacity
    with pytest.raises(cbfgen.CbfError, match="fixed-count"):
        T3.filter(capacity={"foot_height": 2})
    # Built from the parameters themselves.
    from_params = T3.filter(params)
    assert from_params.row_count == rows and from_params.update(x, u_ref, params).source == "qp"
    assert cbfgen.EcbfFilter(T3, params).row_count == rows
    # Built with no capacity: the first update's parameters give theirs, once.
    first = T3.filter()
    assert first.update(x, u_ref, params).source == "qp" and first.row_count == rows
    fixed = "build the filter from the parameters, system.filter\\(params\\)"
    with pytest.raises(cbfgen.CbfError, match=f"other capacities than the filter: {fixed}"):
        first.update(x, u_ref, T3.params())
    assert first.update(x, u_ref, params).source == "qp"
    # Neither a dict nor Params, or another system's: refused.
    with pytest.raises(ValueError, match="a {family: count} dict, or the Params"):
        T3.filter(capacity=5)
    with pytest.raises(ValueError, match="parameters of system double_integrator for a filter of system tachyon3"):
        T3.filter(cbfgen.System("double_integrator").params())


@pytest.mark.parametrize("name", SYSTEMS)
def test_rows_check_their_arguments(name):
    system = cbfgen.System(name)
    x, params = nominal_state(system), ready_params(system)
    rows = system.rows(x, params)
    assert len(rows) == len(rows.layout) == system.filter().row_count
    assert_finite(rows.lie, rows.lg_lf)
    for bad_x in (np.append(x, 0.0), x[:-1], x.reshape(1, -1), x + 0j):
        with pytest.raises(ValueError):
            system.rows(bad_x, params)
    for t in (np.nan, np.inf, -np.inf, 1e300, -F64_MAX):
        with pytest.raises(cbfgen.CbfError, match="time"):
            system.rows(x, params, t)
    with pytest.raises(TypeError):
        system.rows(x, None)


# ---------------------------------------------------------- solver settings
@pytest.mark.parametrize("time_limit_us", [1e26, F64_MAX, np.inf, np.nan, 0.0, -1.0, 2e6])
@pytest.mark.parametrize("system", SYSTEMS)
def test_a_time_limit_outside_the_domain_raises(system, time_limit_us):
    # 1e26 µs used to panic in Duration::from_secs_f64; a 1 kHz filter has no use for
    # a limit of seconds.
    with pytest.raises(cbfgen.CbfError, match="time_limit_us"):
        cbfgen.EcbfFilter(system, time_limit_us=time_limit_us)


@pytest.mark.parametrize("system", SYSTEMS)
def test_time_limits_up_to_the_documented_maximum_are_accepted(system):
    sys_ = cbfgen.System(system)
    for us in (F64_TINY * 1e6, 1e-3, 500.0, cbfgen.MAX_TIME_LIMIT_US):
        safety = cbfgen.EcbfFilter(system, time_limit_us=us)
        assert_finite(safety.update(nominal_state(sys_), np.zeros(sys_.nu), ready_params(sys_)).u)


@pytest.mark.parametrize("settings, name", [
    # Together these ran one update() for hours while holding the GIL; each one alone
    # is outside the solver's documented domain.
    ({"max_iter": 2**32 - 1, "eps_abs": F64_TINY, "eps_rel": F64_TINY}, "max_iter|eps_abs|eps_rel"),
    ({"max_iter": 2**32 - 1}, "max_iter"),
    ({"eps_abs": F64_TINY}, "eps_abs"),
    ({"eps_rel": F64_TINY}, "eps_rel"),
])
@pytest.mark.parametrize("system", SYSTEMS)
def test_solver_settings_that_could_hang_an_update_raise(system, settings, name):
    with pytest.raises(cbfgen.CbfError, match=name):
        cbfgen.EcbfFilter(system, **settings)


@pytest.mark.parametrize("system", SYSTEMS)
def test_the_slowest_accepted_solver_settings_end_an_update(system):
    # The most iterations at the tightest tolerances: an update still ends (in
    # milliseconds), and the child's timeout catches a regression to hours.
    state = ("t3.Course('step').initial_state()" if system == "tachyon3"
             else f"np.resize(np.array([0.1, -0.2]), cbfgen.System('{system}').nx)")
    expression = (f"cbfgen.EcbfFilter('{system}', max_iter=cbfgen.MAX_ITERATIONS, eps_abs=1e-12, eps_rel=1e-12)"
                  f".update({state}, np.ones(cbfgen.System('{system}').nu), ready_params(cbfgen.System('{system}')))"
                  ".source")
    assert run_isolated(expression).startswith("returned: ")


@pytest.mark.parametrize("settings, error, message", [
    ({"activation": {"{f}": np.nan}}, cbfgen.CbfError, "activation threshold must be finite"),
    ({"priority": {"{f}": 16}}, cbfgen.CbfError, "priority tier"),
    ({"priority": {"{f}": 255}}, cbfgen.CbfError, "priority tier"),
    ({"priority": {"{f}": -1}}, OverflowError, None),
    ({"priority": {"{f}": 1.5}}, TypeError, None),
    ({"poles": {"{f}": "one too few"}}, cbfgen.CbfError, "ECBF poles"),
    ({"poles": {"{f}": "one too many"}}, cbfgen.CbfError, "ECBF poles"),
    ({"poles": {"{f}": "first 0"}}, cbfgen.CbfError, "ECBF pole"),
    ({"poles": {"{f}": "first nan"}}, cbfgen.CbfError, "ECBF pole"),
    ({"poles": {"{f}": "first 1e300"}}, cbfgen.CbfError, "ECBF pole"),
    ({"activation": {"no_such_family": 1.0}}, cbfgen.CbfError, "no family named"),
    ({"activation": 1.0}, TypeError, None),
    ({"activation": {"{f}": "high"}}, TypeError, None),
    ({"polish": "yes"}, TypeError, None),
    ({"time_limit_us": "500"}, TypeError, None),
    ({"no_such_setting": 1}, ValueError, "unknown setting 'no_such_setting'"),
    ({"edges": 20}, ValueError, "unknown setting 'edges'"),
    ({"input_weights": [0.0]}, cbfgen.CbfError, "input weight"),
    ({"input_weights": [1e300]}, cbfgen.CbfError, "input weight"),
    ({"input_weights": [1.0, 1.0]}, ValueError, r"input_weights: expected shape"),
    ({"input_min": [1.0], "input_max": [0.0]}, cbfgen.CbfError, "input_min"),
    ({"input_min": [np.nan]}, cbfgen.CbfError, "input limit"),
])
@pytest.mark.parametrize("system", SYSTEMS)
def test_filter_settings_outside_their_domain_raise(system, settings, error, message):
    sys_ = cbfgen.System(system)
    first = sys_.families[0]["name"]
    # Pole lists are stated against the family's own relative degree (one pole each).
    degree = sys_.families[0]["relative_degree"]
    poles = {"one too few": [10.0] * (degree - 1), "one too many": [10.0] * (degree + 1),
             "first 0": [0.0] + [10.0] * (degree - 1), "first nan": [np.nan] + [10.0] * (degree - 1),
             "first 1e300": [1e300] + [10.0] * (degree - 1)}

    def for_system(value):
        if isinstance(value, dict):
            return {first if k == "{f}" else k: poles.get(v, v) if isinstance(v, str) else v
                    for k, v in value.items()}
        if isinstance(value, list) and len(value) == 1:  # one value per input
            return value * sys_.nu
        return value

    kw = {k: for_system(v) for k, v in settings.items()}
    with pytest.raises(error, match=message):
        cbfgen.EcbfFilter(system, **kw)
    with pytest.raises(error, match=message):
        sys_.filter(**kw)


# ---------------------------------------------------------------- simulation
@pytest.mark.parametrize("max_time", ["1e300", "1e4", "t3.MAX_SIM_TIME * (1 + 1e-15)", "float('inf')", "0.0",
                                      "-1.0", "float('nan')"])
def test_a_simulation_length_outside_the_domain_raises(max_time):
    # 1e300 s used to panic (capacity overflow) reserving a sample per cycle.
    assert run_isolated(f"t3.simulate('step', max_time={max_time})").startswith("CbfError: max_time")


def test_the_longest_simulation_does_not_reserve_memory_up_front():
    # max_time used to reserve a sample per cycle before the first one: 6e5 samples of
    # over 300 bytes at MAX_SIM_TIME. The step course completes after about 16 s, so a
    # run that only grows with its cycles needs a few MB, far below this headroom.
    outcome = run_isolated("t3.simulate('step', max_time=t3.MAX_SIM_TIME)['summary']['completed']",
                           headroom=100 << 20)
    assert outcome == "returned: True"


# ------------------------------------------------------------ filter inputs
def cycles(system: str, count: int, seed: int):
    """``(x, u_ref, params, t)``: for Tachyon 3, states scattered around the step
    scenario's start with the course's nominal input and environment (the conditions the
    fuzz run found NaN outputs in); for another system, random states and inputs with
    every family's parameters set."""
    rng = np.random.default_rng(seed)
    if system == "tachyon3":
        course = t3.Course("step")
        x0 = course.initial_state()
        for _ in range(count):
            x = x0 + rng.normal(0.0, 0.02, t3.NX)
            yield x, course.plan(0.0, x), course.environment, 0.0
        return
    sys_ = cbfgen.System(system)
    params = sys_.params()
    for f in sys_.families:
        if f["params"] and f["instances"] != "capacity":
            params.set(f["name"], sample_values(f, 0.5), **({"member": 0} if f["members"] else {}))
    for _ in range(count):
        yield (rng.normal(0.0, 0.5, sys_.nx), rng.normal(0.0, 5.0, sys_.nu), params, float(rng.uniform(0.0, 10.0)))


def filter_for(system: str, **settings) -> cbfgen.EcbfFilter:
    """The filter of ``system`` sized for the parameters ``cycles`` hands out (Tachyon 3:
    the course's, with room for 20 edge cuboids and the paper's footholds)."""
    if system == "tachyon3":
        return t3.ecbf_filter(**settings)
    return cbfgen.EcbfFilter(system, **settings)


@pytest.mark.parametrize("value", [F64_MAX, -F64_MAX, 1e300])
@pytest.mark.parametrize("system, column", [("tachyon3", 0), ("tachyon3", 3), ("tachyon3", 4), ("tachyon3", 16),
                                            ("double_integrator", 0)])
def test_a_huge_nominal_input_raises_and_leaves_the_filter_usable(system, column, value):
    # One entry of f64::MAX made update() return an all-NaN u labelled "qp".
    sys_ = cbfgen.System(system)
    safety = filter_for(system)
    u_ref = np.zeros(sys_.nu)
    u_ref[column] = value
    params = next(cycles(system, 1, seed=0))[2]
    with pytest.raises(cbfgen.CbfError, match="u_ref|input"):
        safety.update(nominal_state(sys_), u_ref, params)
    for x, u_ref, params, t in cycles(system, 20, seed=column):
        out = safety.update(x, u_ref, params, t)
        assert_finite(out.u)


BAD_CYCLES = {
    "nan_state": lambda x, u, p, t: (np.where(np.arange(x.size) == 0, np.nan, x), u, p, t),
    "inf_state": lambda x, u, p, t: (np.where(np.arange(x.size) == x.size - 1, -np.inf, x), u, p, t),
    "huge_state": lambda x, u, p, t: (x * 0 + 1e300, u, p, t),
    "nan_input": lambda x, u, p, t: (x, u * np.nan, p, t),
    "nan_time": lambda x, u, p, t: (x, u, p, np.nan),
    "huge_time": lambda x, u, p, t: (x, u, p, 1e300),
    "short_state": lambda x, u, p, t: (x[:-1], u, p, t),
    "matrix_input": lambda x, u, p, t: (x, u.reshape(1, -1), p, t),
    "complex_state": lambda x, u, p, t: (x + 0j, u, p, t),
}


@pytest.mark.parametrize("bad", sorted(BAD_CYCLES))
@pytest.mark.parametrize("system", SYSTEMS)
def test_one_bad_cycle_raises_and_does_not_poison_the_next(system, bad):
    safety = filter_for(system)
    good = list(cycles(system, 6, seed=3))
    for cycle in good:
        before = safety.output
        with pytest.raises(ValueError):  # CbfError for values, ValueError for shapes and dtypes
            safety.update(*BAD_CYCLES[bad](*cycle))
        assert np.array_equal(safety.output.u, before.u) and safety.output.source == before.source
        out = safety.update(*cycle)
        assert_finite(out.u, safety.slack)


@pytest.mark.parametrize("system", SYSTEMS)
def test_input_limits_beyond_the_domain_raise(system):
    # input_min = input_max = 1e307 used to be accepted and give NaN labelled "qp".
    nu = cbfgen.System(system).nu
    with pytest.raises(cbfgen.CbfError, match="input limit"):
        cbfgen.EcbfFilter(system, input_min=[1e307] * nu, input_max=[1e307] * nu)


@pytest.mark.parametrize("limit", [cbfgen.MAX_INPUT, -cbfgen.MAX_INPUT, 0.0])
@pytest.mark.parametrize("system", SYSTEMS)
def test_a_degenerate_input_box_inside_the_domain_never_yields_a_non_finite_input(system, limit):
    nu = cbfgen.System(system).nu
    safety = filter_for(system, input_min=[limit] * nu, input_max=[limit] * nu)
    for x, u_ref, params, t in cycles(system, 200, seed=1):
        out = safety.update(x, u_ref, params, t)
        assert np.all(np.isfinite(out.u)), (out, out.u)
        assert np.all(np.isfinite(safety.fallback_input(u_ref)))


def test_a_toe_at_its_hip_gives_the_filter_a_finite_fallback():
    safety = t3.ecbf_filter()
    out = safety.update(toe_at_hip(), np.zeros(t3.NU), t3.Environment())
    assert_finite(out.u)
    assert out.source != "qp" and out.nonfinite_row is not None
    assert safety.layout[out.nonfinite_row][:2] == ("joint_limits", "lf")
    # ... and the next ordinary cycle solves again.
    assert safety.update(t3.standard_posture(), np.zeros(t3.NU), t3.Environment()).source == "qp"


# ------------------------------------------------------------------ kernels
def kernels(system: str) -> dict:
    """Every state-taking entry point of ``system`` (its rows, dynamics and filter;
    Tachyon 3's kinematics and course too), as functions of the state."""
    sys_ = cbfgen.System(system)
    out = {
        "drift": sys_.drift,
        "input_matrix": sys_.input_matrix,
        "xdot": lambda x: sys_.xdot(x, np.ones(sys_.nu)),
        "rows": lambda x: (lambda r: (r.lie, r.lg_lf))(sys_.rows(x, sys_.params(capacity_of_every(sys_, 1)))),
        "filter_update": lambda x: sys_.filter().update(x, np.zeros(sys_.nu), sys_.params()).u,
    }
    if system == "tachyon3":
        out.update({
            "world_kinematics": t3.world_kinematics,
            "course_plan": lambda x: t3.Course("step").plan(0.0, x),
            "course_clearance": lambda x: t3.Course("step").clearance(x),
        })
    return out


KERNELS = [(s, k) for s in SYSTEMS for k in sorted(kernels(s))]


def beyond_the_domain(system: str) -> list[np.ndarray]:
    sys_ = cbfgen.System(system)
    x0 = nominal_state(sys_)
    one_huge = x0.copy()
    one_huge[0] = 1e300
    just_past = x0.copy()
    just_past[-1] = np.nextafter(cbfgen.STATE_LIMIT, np.inf)
    return [one_huge, np.full(sys_.nx, F64_MAX), np.full(sys_.nx, -1e200), x0 + 2e6, just_past,
            x0 * 0 + 1e300 * np.sign(x0 + 0.5)]


@pytest.mark.parametrize("index", range(6))
@pytest.mark.parametrize("system, kernel", KERNELS)
def test_states_beyond_the_domain_raise(system, kernel, index):
    # Such states used to give NaN or inf rows without an error.
    with pytest.raises(cbfgen.CbfError, match="state entry"):
        kernels(system)[kernel](beyond_the_domain(system)[index])


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("system, kernel", KERNELS)
def test_states_at_the_edge_of_the_domain_give_finite_values_or_raise(system, kernel, seed):
    # Entries of magnitude STATE_LIMIT: finite values, or a CbfError (a row that is not
    # finite at singular geometry; a box derived from the state beyond the box domain),
    # never NaN handed back.
    nx = cbfgen.System(system).nx
    rng = np.random.default_rng(seed)
    x = rng.choice([-1.0, 1.0], nx) * cbfgen.STATE_LIMIT * rng.choice([1.0, 1e-3, 1e-6], nx)
    try:
        result = kernels(system)[kernel](x)
    except cbfgen.CbfError:
        return
    assert_finite(*(result if isinstance(result, tuple) else (result,)))


@pytest.mark.parametrize("shape", [(1, -1), (-1, 1)])
@pytest.mark.parametrize("system", SYSTEMS)
def test_vectors_must_be_one_dimensional(system, shape):
    sys_ = cbfgen.System(system)
    x = nominal_state(sys_)
    for call in (sys_.drift, sys_.input_matrix, lambda y: sys_.xdot(y, np.zeros(sys_.nu)),
                 lambda y: sys_.rows(y, sys_.params())):
        with pytest.raises(ValueError, match=rf"x: expected shape \({sys_.nx},\), got shape"):
            call(x.reshape(shape))
    with pytest.raises(ValueError, match=rf"u: expected shape \({sys_.nu},\)"):
        sys_.xdot(x, np.zeros(sys_.nu).reshape(shape))
    with pytest.raises(ValueError, match=r"expected shape \(36,\), got shape \(6, 6\)"):
        T3.drift(t3.standard_posture().reshape(6, 6))


def kernel_inputs(module: str, inputs: list) -> np.ndarray:
    """Inputs inside every kernel's domain, by argument name."""
    parts = []
    for name, n in inputs:
        if name == "x":
            parts.append(nominal_state(cbfgen.System(module)))
        elif name.startswith("r_") or name == "rotation":
            parts.append(np.eye(3).ravel())
        elif name == "frame":  # a link frame's pose (kernels on a frame's jet): off the origin, turned by I
            parts.append([0.1, 0.2, 0.3, *np.eye(3).ravel()])
        elif name.startswith("p_b"):
            parts.append([1.5, 0.2, 0.1])
        elif name.startswith("alpha"):
            parts.append([200.0])
        elif name == "t":
            parts.append([0.5])
        else:
            parts.append(np.full(n, 0.25))
    return np.concatenate([np.ravel(p) for p in parts])


KERNEL_TABLE = cbfgen.kernel_table()


@pytest.mark.parametrize("module, name, inputs, outputs", KERNEL_TABLE, ids=[f"{k[0]}.{k[1]}" for k in KERNEL_TABLE])
def test_every_kernel_checks_its_inputs(module, name, inputs, outputs):
    good = kernel_inputs(module, inputs)
    out = cbfgen.call_kernel(module, name, good)
    assert out.shape == (sum(n for _, n in outputs),)
    assert_finite(out)
    for i in (0, len(good) - 1):
        for value in (np.nan, np.inf, -np.inf):
            bad = good.copy()
            bad[i] = value
            with pytest.raises(cbfgen.CbfError, match="kernel input must be finite"):
                cbfgen.call_kernel(module, name, bad)
    with pytest.raises(cbfgen.CbfError, match=f"expected length {len(good)}, got {len(good) - 1}"):
        cbfgen.call_kernel(module, name, good[:-1])
    for too_many in (np.append(good, 0.0), np.zeros(10**7)):  # the count is checked before any copy
        with pytest.raises(cbfgen.CbfError, match=f"too many kernel inputs: capacity is {len(good)}"):
            cbfgen.call_kernel(module, name, too_many)
    with pytest.raises(ValueError, match=r"expected a vector"):
        cbfgen.call_kernel(module, name, good.reshape(1, -1))
    with pytest.raises(ValueError, match="complex128"):
        cbfgen.call_kernel(module, name, good + 0j)


@pytest.mark.parametrize("module, name", [("tachyon3", "no_such_kernel"), ("no_such_module", "drift"),
                                          ("ssat", "drift"), ("", "")])
def test_an_unknown_kernel_raises(module, name):
    # A KeyError (a LookupError), where other unknown names are ValueError: see the
    # report of the port to the generic API.
    with pytest.raises((KeyError, ValueError), match="no generated kernel"):
        cbfgen.call_kernel(module, name, np.zeros(36))


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
        with pytest.raises(cbfgen.CbfError, match=message):
            t3.Environment(edges=1).push_edge(p_b, np.eye(3), half_b)


# ------------------------------------------------------------ arrays in
@pytest.mark.parametrize("call", [
    lambda c: T3.drift(t3.standard_posture() + c),
    lambda c: DI.drift(np.zeros(2) + c),
    lambda c: T3.xdot(t3.standard_posture(), np.zeros(t3.NU) + c),
    lambda c: DI.rows(np.zeros(2) + c, DI.params()),
    lambda c: cbfgen.ssat(BOX[0], np.eye(3) + c, *BOX[2:], *BOX),
    lambda c: cbfgen.EcbfFilter("tachyon3", input_min=-np.ones(t3.NU) + c),
    lambda c: DI.filter(input_weights=np.ones(1) + c),
    lambda c: t3.ecbf_filter().update(t3.standard_posture(), np.zeros(t3.NU) + c, t3.Environment()),
    lambda c: t3.Environment().set_foothold(0, np.array([[1.0, 0.0]]) + c, [0.5]),
    lambda c: DI.params().set("sine_barrier", np.zeros(3) + c),
    lambda c: t3.Environment().push("body_edge", {"center": np.zeros(3) + c, "rotation": np.eye(3), "half": [1] * 3}),
    lambda c: cbfgen.call_kernel("double_integrator", "drift", np.zeros(2) + c),
])
@pytest.mark.parametrize("imaginary", [0j, 1j])
def test_complex_arrays_are_refused(call, imaginary):
    # numpy's cast to float64 drops the imaginary part: even 0j is refused, by dtype.
    with pytest.raises(ValueError, match="complex128"):
        call(imaginary)


@pytest.mark.parametrize("kind", ["strings", "none", "objects"])
@pytest.mark.parametrize("system", SYSTEMS)
def test_strings_and_objects_are_refused(system, kind):
    sys_ = cbfgen.System(system)
    values = {"strings": ["0.1"] * sys_.nu, "none": [None] * sys_.nu, "objects": [object()] * sys_.nu}[kind]
    with pytest.raises(ValueError, match="expected real numbers"):
        sys_.xdot(nominal_state(sys_), values)
    with pytest.raises(ValueError, match="expected real numbers"):
        sys_.filter().update(nominal_state(sys_), values, sys_.params())


@pytest.mark.parametrize("dtype", [np.float32, np.int64, np.uint8, np.bool_, np.longdouble, ">f8"])
@pytest.mark.parametrize("system", SYSTEMS)
def test_real_arrays_of_any_dtype_are_read_as_float64(system, dtype):
    sys_ = cbfgen.System(system)
    x = nominal_state(sys_)
    u = np.ones(sys_.nu)
    np.testing.assert_array_equal(sys_.xdot(x, u.astype(dtype)), sys_.xdot(x, u))


def test_foothold_normals_must_be_k_by_2():
    env = t3.Environment()
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
    # The generic form: one half-plane at a time, its normal of shape (2,).
    for normal in ([1.0, 0.0, 0.0], [[1.0, 0.0]], [[1.0], [0.0]]):
        with pytest.raises(ValueError, match=r"normal: expected shape \(2,\)"):
            env.push("foothold", {"normal": normal, "offset": 0.1}, member="lf")
    assert env.count("foothold", member="lf") == 0


def test_rotations_are_9_values_or_3_by_3():
    yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    as_matrix = cbfgen.ssat(BOX[0], yaw, [0.5, 0.2, 0.1], [1.0, 0.3, 0.0], np.eye(3), [0.5, 0.5, 0.5])
    as_values = cbfgen.ssat(BOX[0], yaw.ravel(), [0.5, 0.2, 0.1], [1.0, 0.3, 0.0], np.eye(3), [0.5, 0.5, 0.5])
    assert as_matrix == as_values
    # A Fortran-ordered 3x3 is still read row by row.
    assert as_matrix == cbfgen.ssat(BOX[0], np.asfortranarray(yaw), [0.5, 0.2, 0.1], [1.0, 0.3, 0.0],
                                    np.eye(3), [0.5, 0.5, 0.5])
    for shape in [(1, 9), (9, 1), (3, 3, 1)]:
        with pytest.raises(ValueError, match=r"shape \(3, 3\) or its 9 values row by row"):
            cbfgen.ssat(BOX[0], np.eye(3).reshape(shape), *BOX[2:], *BOX)


def test_a_reflection_is_reported_by_its_determinant():
    # It used to say "deviation 0.000e0", which read as if the matrix were fine.
    with pytest.raises(cbfgen.CbfError, match=r"det R = -1\.0"):
        cbfgen.ssat(BOX[0], np.diag([1.0, 1.0, -1.0]), *BOX[2:], *BOX)
    with pytest.raises(cbfgen.CbfError, match=r"det R = -1\.0"):
        t3.Environment().push_edge(BOX[0], np.diag([1.0, 1.0, -1.0]), BOX[2])


def test_course_outputs_are_finite_or_raise():
    course = t3.Course("step")
    for gap in (F64_MAX, -F64_MAX):
        assert_finite(course.initial_state(start_gap=gap))
    x = course.initial_state()
    for t in (0.0, 1e300, F64_MAX, -1e300):
        try:
            assert_finite(course.plan(t, x))
        except cbfgen.CbfError:
            pass
    for t in (np.nan, np.inf):
        with pytest.raises(cbfgen.CbfError, match="time"):
            course.plan(t, x)


# ======================================= values out are finite, or a typed error
# Found porting these tests to the generic API and fixed in the same change: rows that
# apply but are not finite raised nowhere, and the filter left them out of its QP.
DEGENERATE_BOXES = {
    "negative_half": {"center": [0.6, 0.0, 0.3], "rotation": np.eye(3), "half": [-0.1, -0.1, -0.1]},
    "zero_half": {"center": [0.6, 0.0, 0.3], "rotation": np.eye(3), "half": [0.0, 0.0, 0.0]},
    "not_a_rotation": {"center": [0.6, 0.0, 0.3], "rotation": np.full((3, 3), 2.0), "half": [0.1, 0.1, 0.1]},
    "domain_corner": {"center": [-1e6, 1e6, -1e6], "rotation": np.full((3, 3), 1e6), "half": [1e6, -1e6, 1e6]},
}
"""Finite numbers within +-PARAM_LIMIT that are no box. While the toe rows were the paper's
superellipsoid, a negative half extent made them divide by zero, and these tests checked
that such rows raised and made the filter fall back. The generic parameters now refuse
them as push_edge does (their domains: half extents in [1e-6, 1e4], a proper rotation),
so no row is evaluated on them; the kernel itself, reached past the domains through the
kernel table, stays finite on every such box: the certified clearance divides only by
square roots of sums with a positive floor. The filter's handling of a NaN h is tested in
systems/tachyon3/tests/integration/filter.rs."""


@pytest.mark.parametrize("box", DEGENERATE_BOXES.values(), ids=DEGENERATE_BOXES.keys())
def test_toe_rows_of_a_degenerate_edge_cuboid_are_finite(box):
    x = t3.standard_posture()
    flat_box = np.concatenate([box["center"], np.ravel(box["rotation"]), box["half"]])
    assert_finite(cbfgen.call_kernel("tachyon3", "toe_edge", np.concatenate([x, flat_box])))


def test_rows_at_a_toe_at_its_hip_raise():
    # The old cbfgen.joint_limits("LF", toe_at_hip()) raised; so do the generic rows.
    with pytest.raises(cbfgen.CbfError, match="constraint row 0 is not finite"):
        T3.rows(toe_at_hip(), t3.Environment())


@pytest.mark.parametrize("box", DEGENERATE_BOXES.values(), ids=DEGENERATE_BOXES.keys())
def test_a_degenerate_edge_cuboid_is_refused_and_the_filter_solves_without_it(box):
    env = t3.Environment(edges=1)
    with pytest.raises(cbfgen.CbfError, match=r"^toe_edge instance 0: parameter (half|rotation) is outside its domain"):
        env.push("toe_edge", box)
    assert env.count("toe_edge") == 0
    safety = t3.ecbf_filter(edges=1)
    out = safety.update(t3.standard_posture(), np.zeros(t3.NU), env)
    assert out.nonfinite_row is None and out.source == "qp"
    assert_finite(out.u)


@pytest.mark.parametrize("x", [t3.standard_posture() * 1e300, toe_at_hip()], ids=["huge_state", "toe_at_hip"])
def test_call_kernel_refuses_inputs_out_of_domain_and_non_finite_outputs(x):
    with pytest.raises(cbfgen.CbfError, match="kernel input|kernel output"):
        cbfgen.call_kernel("tachyon3", "joint_limits_lf", x)
