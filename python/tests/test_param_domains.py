"""Parameter domains from Python: ``Params.set``/``push`` refuse geometry that is not
geometry (half extents <= 0, 2 I, reflections, zero and skewed matrices, non-unit normals,
negative or NaN values) with a ``CbfError`` (a ``ValueError``) naming family, member,
instance and parameter, and change nothing. The truth for the edge cuboids is Tachyon 3's
hand-written ``Environment.push_edge`` (through ``OrientedBox``), which refuses and
accepts the same boxes; for the arm, the domains its primitives give (prim.Box)."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

t3 = cbfgen.tachyon3
CENTER = np.array([0.8, 0.0, 0.06])
HALF = np.array([0.02, 1.0, 0.02])
SKEWED = np.eye(3)
SKEWED[0, 1] = 1e-7  # 100 times the tolerance
EDGE_ROTATION = "a proper rotation: max |RᵀR − I| ≤ 1e-9, det > 0"
EDGE_HALF = "in [1e-6, 10000]"

# (what, centre, rotation, half extents, the message's tail: parameter, domain, what was found)
BAD_EDGES = [
    ("negative half extents", CENTER, np.eye(3), [-0.3, -1.0, -0.3], f"half is outside its domain ({EDGE_HALF}): "
     "half[0] = -0.3"),
    ("a zero half extent", CENTER, np.eye(3), [0.02, 0.0, 0.02], f"half is outside its domain ({EDGE_HALF}): "
     "half[1] = 0"),
    ("2 I", CENTER, 2 * np.eye(3), HALF, f"rotation is outside its domain ({EDGE_ROTATION}): "
     "max |RᵀR − I| of rotation = 3"),
    ("a reflection", CENTER, np.diag([1.0, 1.0, -1.0]), HALF, f"rotation is outside its domain ({EDGE_ROTATION}): "
     "det rotation = -1"),
    ("the zero matrix", CENTER, np.zeros((3, 3)), HALF, f"rotation is outside its domain ({EDGE_ROTATION}): "
     "max |RᵀR − I| of rotation = 1"),
    ("a skewed rotation", CENTER, SKEWED, HALF, f"rotation is outside its domain ({EDGE_ROTATION}): "
     "max |RᵀR − I| of rotation = 1e-7"),
    ("a NaN centre", [0.8, np.nan, 0.06], np.eye(3), HALF, "center is outside its domain (finite, within ±1e6): "
     "center[1] = NaN"),
]


def edge(center, rotation, half) -> dict:
    return {"center": center, "rotation": rotation, "half": half}


def assert_same(got: dict | None, want: dict | None) -> None:
    assert (got is None) == (want is None)
    for name in want or {}:
        np.testing.assert_array_equal(got[name], want[name])


@pytest.mark.parametrize("family", ["body_edge", "toe_edge"])
@pytest.mark.parametrize("what, center, rotation, half, tail", BAD_EDGES, ids=[b[0] for b in BAD_EDGES])
def test_edge_cuboids_that_are_not_boxes_are_refused_as_push_edge_refuses_them(family, what, center, rotation,
                                                                                half, tail):
    params = t3.SYSTEM.params(t3.capacity(2, [0] * 6))
    params.push(family, edge(CENTER, np.eye(3), HALF))
    before = params.get(family)
    with pytest.raises(cbfgen.CbfError) as pushed:
        params.push(family, edge(center, rotation, half))
    assert str(pushed.value) == f"{family} instance 1: parameter {tail}"
    assert isinstance(pushed.value, ValueError)
    with pytest.raises(cbfgen.CbfError, match=f"^{family} instance 0: parameter "):
        params.set(family, edge(center, rotation, half), instance=0)
    assert params.count(family) == 1 and params.get(family, instance=1) is None
    assert_same(params.get(family), before)
    # The hand-written path refuses the same box.
    env = t3.Environment(edges=2)
    with pytest.raises(cbfgen.CbfError):
        env.push_edge(center, rotation, half)
    assert env.edge_count == 0


def test_proper_rotations_within_the_tolerance_are_accepted_by_both_paths():
    within = np.eye(3)
    within[0, 1] = 5e-10
    c, s = np.cos(0.4), np.sin(0.4)
    turned = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    params = t3.SYSTEM.params(t3.capacity(2, [0] * 6))
    env = t3.Environment(edges=2)
    for rotation in (within, turned):
        params.push("body_edge", edge(CENTER, rotation, HALF))
        env.push_edge(CENTER, rotation, HALF)
        np.testing.assert_array_equal(params.get("body_edge", instance=params.count("body_edge") - 1)["rotation"],
                                      rotation)
    assert env.edge_count == 2


def test_a_generic_push_on_the_environment_is_refused_the_same_way():
    env = t3.Environment(edges=2)
    with pytest.raises(cbfgen.CbfError, match=r"^body_edge instance 0: parameter half .*half\[0\] = -0.3$"):
        env.push("body_edge", edge(CENTER, np.eye(3), [-0.3, -1.0, -0.3]))
    assert env.count("body_edge") == 0


def test_foothold_normals_must_have_unit_length_naming_the_leg():
    env = t3.Environment(edges=1, foothold_edges=[2] * 6)
    env.push("foothold", {"normal": [0.6, 0.8], "offset": 0.25}, member="rr")
    with pytest.raises(cbfgen.CbfError) as err:
        env.push("foothold", {"normal": [3.0, 4.0], "offset": 0.25}, member="rr")
    assert str(err.value) == ("foothold member rr instance 1: parameter normal is outside its domain "
                              "(a unit vector: | |v| − 1 | ≤ 1e-9): |normal| = 5")
    with pytest.raises(cbfgen.CbfError, match=r"\|normal\| = 0$"):
        env.set("foothold", {"normal": [0.0, 0.0], "offset": 0.25}, member="rr", instance=0)
    assert env.count("foothold", member="rr") == 1
    env.set_foothold("RR", [[3.0, 4.0]], [1.0])  # the typed helper normalises
    np.testing.assert_allclose(env.foothold("RR")[0], [[0.6, 0.8]], rtol=1e-15)


ARM = cbfgen.System("panda")


@pytest.mark.parametrize("rotation, half, tail", [
    (np.eye(3), [0.1, -0.2, 0.3], "half is outside its domain (> 0): half[1] = -0.2"),
    (np.eye(3), [0.1, 0.2, 0.0], "half is outside its domain (> 0): half[2] = 0"),
    (2 * np.eye(3), [0.1, 0.2, 0.3], f"rotation is outside its domain ({EDGE_ROTATION}): "
     "max |RᵀR − I| of rotation = 3"),
    (np.diag([-1.0, 1.0, 1.0]), [0.1, 0.2, 0.3], f"rotation is outside its domain ({EDGE_ROTATION}): "
     "det rotation = -1"),
    (np.zeros((3, 3)), [0.1, 0.2, 0.3], f"rotation is outside its domain ({EDGE_ROTATION}): "
     "max |RᵀR − I| of rotation = 1"),
    (np.eye(3), [0.1, np.nan, 0.3], "half is outside its domain (finite, within ±1e6): half[1] = NaN"),
])
def test_the_arm_refuses_obstacles_that_are_not_boxes_naming_the_link(rotation, half, tail):
    params = ARM.params({"obstacle": 2})
    params.push("obstacle", edge([0.5, 0.0, 0.3], np.eye(3), [0.1, 0.2, 0.3]), member="link3")
    before = params.get("obstacle", member="link3")
    with pytest.raises(cbfgen.CbfError) as err:
        params.push("obstacle", edge([0.5, 0.0, 0.3], rotation, half), member="link3")
    assert str(err.value) == f"obstacle member link3 instance 1: parameter {tail}"
    with pytest.raises(ValueError, match="^obstacle member link3 instance 0: "):
        params.set("obstacle", edge([0.5, 0.0, 0.3], rotation, half), member="link3", instance=0)
    assert params.count("obstacle", member="link3") == 1
    assert_same(params.get("obstacle", member="link3"), before)


def test_a_non_finite_scalar_is_refused_and_the_instance_kept():
    system = cbfgen.System("double_integrator")
    params = system.params()
    params.set("sine_barrier", {"amplitude": 0.2, "omega": 2.0, "offset": -0.5})
    with pytest.raises(cbfgen.CbfError) as err:
        params.set("sine_barrier", {"amplitude": 0.2, "omega": np.inf, "offset": -0.5})
    assert str(err.value) == ("sine_barrier instance 0: parameter omega is outside its domain "
                              "(finite, within ±1e6): omega = inf")
    assert params.get("sine_barrier") == {"amplitude": 0.2, "omega": 2.0, "offset": -0.5}
