"""ANYmal C in Pinocchio, for the tests that check generated models against it: the free
flyer of the same URDF, with a frame at each foot sphere's centre."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from symbolic import urdf

LEGS = ["LF", "RF", "LH", "RH"]
JOINTS = [f"{leg}_{j}" for leg in LEGS for j in ("HAA", "HFE", "KFE")]
PATH = urdf.description("anymal_c_simple_description/urdf/anymal.urdf")


def model_with_feet() -> tuple[pin.Model, list[int], urdf.Urdf]:
    """Pinocchio's free-flyer model, the ids of a frame at each foot sphere's centre (on
    the foot link) in ``LEGS`` order, and the URDF as the spec reads it."""
    robot = urdf.load(PATH)
    model = pin.buildModelFromUrdf(str(PATH), pin.JointModelFreeFlyer())
    feet = []
    for leg in LEGS:
        sphere = next(s for s in urdf.collision_shapes(robot, f"{leg}_FOOT") if isinstance(s, urdf.Sphere))
        foot = model.getFrameId(f"{leg}_FOOT", pin.FrameType.BODY)
        placement = model.frames[foot].placement * pin.SE3(np.eye(3), np.array(sphere.center))
        feet.append(model.addFrame(pin.Frame(f"{leg}_FOOT_CENTRE", model.frames[foot].parentJoint, foot, placement,
                                             pin.FrameType.OP_FRAME)))
    return model, feet, robot
