"""Pinocchio's cost for what cbfgen generates, called from Python on this machine: the
peer figures beside `cargo bench -p cbfgen-panda --bench arm` (arm_dynamics,
arm_kinematics) and `cargo bench -p cbfgen-anymal` (anymal/feet).

    scripts/cbf python scripts/pinocchio_peer.py

Each figure is the median over 7 repeats of the mean of 20 000 calls (timeit), so it
includes the Python binding's call overhead; `pin.neutral` (an almost empty call) is
printed as that overhead's measure. Models: the Panda from example-robot-data's URDF (9
joints, fingers included: Pinocchio's model of the file), ANYmal C on a free flyer.
"""

from __future__ import annotations

import statistics
import sys
import timeit
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository's symbolic/
from symbolic import urdf  # noqa: E402

CALLS = 20_000
REPEATS = 7


def median_us(statement) -> float:
    return statistics.median(timeit.repeat(statement, number=CALLS, repeat=REPEATS)) / CALLS * 1e6


def main() -> None:
    rng = np.random.default_rng(0)
    panda = pin.buildModelFromUrdf(str(urdf.description("panda_description/urdf/panda.urdf")))
    data = panda.createData()
    q = np.concatenate([rng.uniform(panda.lowerPositionLimit[:7], panda.upperPositionLimit[:7]), [0.04, 0.04]])
    v = rng.uniform(-1, 1, panda.nv)
    hand = panda.getFrameId("panda_hand", pin.FrameType.BODY)
    rows = [
        ("panda: pin.neutral (call overhead)", lambda: pin.neutral(panda)),
        ("panda: pin.crba (M)", lambda: pin.crba(panda, data, q)),
        ("panda: pin.nonLinearEffects (C v + g)", lambda: pin.nonLinearEffects(panda, data, q, v)),
        ("panda: pin.framesForwardKinematics (every frame)", lambda: pin.framesForwardKinematics(panda, data, q)),
        ("panda: pin.computeFrameJacobian (hand, LOCAL_WORLD_ALIGNED)",
         lambda: pin.computeFrameJacobian(panda, data, q, hand, pin.LOCAL_WORLD_ALIGNED)),
    ]
    anymal = pin.buildModelFromUrdf(str(urdf.description("anymal_c_simple_description/urdf/anymal.urdf")),
                                    pin.JointModelFreeFlyer())
    adata = anymal.createData()
    qa = pin.randomConfiguration(anymal, -np.ones(anymal.nq), np.ones(anymal.nq))
    qa[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3)).coeffs()
    va = rng.uniform(-1, 1, anymal.nv)
    feet = [anymal.getFrameId(f"{leg}_FOOT", pin.FrameType.BODY) for leg in ("LF", "RF", "LH", "RH")]

    def anymal_feet():
        pin.forwardKinematics(anymal, adata, qa, va)
        for f in feet:
            pin.updateFramePlacement(anymal, adata, f)
            pin.getFrameVelocity(anymal, adata, f, pin.LOCAL_WORLD_ALIGNED)

    rows.append(("anymal: forwardKinematics(q, v) + 4 frame placements and velocities", anymal_feet))
    print(f"Pinocchio {pin.__version__}, Python-called; median of {REPEATS} x {CALLS} calls")
    for name, call in rows:
        print(f"{median_us(call):8.2f} us  {name}")


if __name__ == "__main__":
    main()
