"""The 7-DoF arm (systems/panda/spec/panda.py) through the generic bindings: its spec's
families as the module reports them, and the example's closed loop (examples/arm_filter.py)
keeping every certified obstacle row non-negative, which it does not without the filter."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "arm_filter.py"


def _example():
    pytest.importorskip("matplotlib")
    spec = importlib.util.spec_from_file_location("arm_filter", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_arm_is_a_built_in_system_with_four_families_of_two_degrees():
    assert "panda" in cbfgen.systems()
    arm = cbfgen.System("panda")
    assert (arm.nx, arm.nu) == (14, 7)
    degrees = {f["name"]: f["relative_degree"] for f in arm.families}
    assert degrees == {"joint_limits": 2, "velocity_limits": 1, "obstacle": 2, "self_collision": 2}
    members = {f["name"]: f["members"] for f in arm.families}
    # One obstacle member per moving link box, one self-collision member per SRDF pair.
    assert len(members["obstacle"]) == 10 and len(members["self_collision"]) == 20


def test_the_filter_keeps_the_obstacle_certificates_and_the_pd_alone_does_not():
    example = _example()
    with_filter = example.run(2.0, filtered=True)
    without = example.run(2.0, filtered=False)
    assert with_filter["min_obstacle_h"].min() >= -1e-6
    assert without["min_obstacle_h"].min() < -0.05


def test_the_compiled_hand_pose_and_jacobian_are_pinocchios():
    # The generated `hand` output, called in Rust, against Pinocchio reading the same URDF
    # at 10^4 random configurations within the joint limits (fingers open: they are below
    # the hand and move neither its pose nor its Jacobian).
    pin = pytest.importorskip("pinocchio", reason="installed from symbolic/requirements-test.txt")
    import numpy as np

    from symbolic import urdf

    model = pin.buildModelFromUrdf(str(urdf.description("panda_description/urdf/panda.urdf")))
    data = model.createData()
    hand = model.getFrameId("panda_hand", pin.FrameType.BODY)
    lower, upper = model.lowerPositionLimit[:7], model.upperPositionLimit[:7]
    rng = np.random.default_rng(3535)
    worst = 0.0
    for _ in range(10_000):
        q = rng.uniform(lower, upper)
        got = cbfgen.call_kernel("panda", "hand", np.concatenate([q, rng.uniform(-1, 1, 7)]))
        q_pin = np.concatenate([q, [0.04, 0.04]])
        jacobian = pin.computeFrameJacobian(model, data, q_pin, hand, pin.LOCAL_WORLD_ALIGNED)[:, :7]
        placement = data.oMf[hand]
        want = np.concatenate([placement.translation, placement.rotation.ravel(), jacobian.ravel()])
        worst = max(worst, float(np.max(np.abs(got - want))))
    assert worst <= 1e-12, worst
