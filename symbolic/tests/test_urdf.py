"""The URDF front end against Pinocchio reading the same files: every link's pose at 10^4
random configurations within the joint limits, to 1e-12; and a broken URDF is a
SpecError naming the element."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin  # `pin` on PyPI, with example-robot-data: symbolic/requirements-test.txt
import pytest
import symengine as se

from symbolic import urdf
from symbolic.spec import SpecError

ROBOTS = [
    "panda_description/urdf/panda.urdf",
    "ur_description/urdf/ur5_robot.urdf",
    "anymal_c_simple_description/urdf/anymal.urdf",
    "solo_description/robots/solo12.urdf",
]
CONFIGURATIONS = 10_000


def _random_configurations(robot: urdf.Urdf, rng: np.random.Generator) -> np.ndarray:
    columns = []
    for j in robot.moving_joints:
        lo = -math.pi if j.lower is None or j.type == "continuous" else j.lower
        hi = math.pi if j.upper is None or j.type == "continuous" else j.upper
        columns.append(rng.uniform(lo, hi, CONFIGURATIONS))
    return np.stack(columns, axis=1)


@pytest.mark.parametrize("relative", ROBOTS)
def test_every_link_pose_matches_pinocchio(relative):
    path = urdf.description(relative)
    robot = urdf.load(path)
    q = {j.name: se.Symbol(f"q_{k}") for k, j in enumerate(robot.moving_joints)}
    fk = urdf.Kinematics(robot, q)
    links = list(robot.links)
    flat = [e for link in links for r, p in [fk.pose(link)] for e in [*sum(r, []), *p]]
    ours = se.Lambdify(list(q.values()), flat)

    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    frames = [model.getFrameId(link, pin.FrameType.BODY) for link in links]
    rng = np.random.default_rng(35)
    configurations = _random_configurations(robot, rng)
    worst = 0.0
    for values in configurations:
        q_pin = np.zeros(model.nq)
        for name, v in zip(q, values, strict=True):
            joint = model.joints[model.getJointId(name)]
            if joint.nq == 2:  # a continuous joint: Pinocchio stores (cos, sin)
                q_pin[joint.idx_q:joint.idx_q + 2] = (math.cos(v), math.sin(v))
            else:
                q_pin[joint.idx_q] = v
        pin.framesForwardKinematics(model, data, q_pin)
        got = np.asarray(ours(values)).reshape(len(links), 12)
        for k, f in enumerate(frames):
            placement = data.oMf[f]
            want = np.concatenate([placement.rotation.ravel(), placement.translation])
            worst = max(worst, float(np.max(np.abs(got[k] - want))))
    assert worst <= 1e-12, f"{relative}: largest pose difference {worst:.3g}"


def _write(tmp_path: Path, joints: str, links: str = "<link name='a'/><link name='b'/><link name='c'/>") -> Path:
    path = tmp_path / "broken.urdf"
    path.write_text(f"<robot name='broken'>{links}{joints}</robot>")
    return path


def _joint(name: str, parent: str, child: str, kind: str = "revolute", axis: str = "0 0 1") -> str:
    return (f"<joint name='{name}' type='{kind}'><parent link='{parent}'/><child link='{child}'/>"
            f"<axis xyz='{axis}'/></joint>")


@pytest.mark.parametrize("joints, message", [
    (_joint("j1", "a", "b", kind="screw") + _joint("j2", "b", "c"), "joint 'j1': type 'screw' is not one of"),
    (_joint("j1", "a", "b", axis="0 0 2") + _joint("j2", "b", "c"), "joint 'j1': axis (0.0, 0.0, 2.0) is not a unit"),
    (_joint("j1", "a", "b") + _joint("j2", "b", "c") + _joint("j3", "c", "b"),
     "joint 'j3': link 'b' already has parent 'a'"),
    (_joint("j1", "a", "b") + _joint("j2", "b", "d"), "joint 'j2': child link 'd' is not a link"),
    (_joint("j1", "a", "b"), "2 links without a parent (['a', 'c'])"),
])
def test_a_broken_urdf_names_the_element(tmp_path, joints, message):
    with pytest.raises(SpecError) as err:
        urdf.load(_write(tmp_path, joints))
    assert message in str(err.value) and "broken.urdf" in str(err.value)


def test_a_loop_is_named(tmp_path):
    # b's parent is c and c's is b: every link has one parent, a is the root, b and c loop.
    joints = _joint("j1", "c", "b") + _joint("j2", "b", "c")
    with pytest.raises(SpecError, match=r"links \['b', 'c'\] form a loop"):
        urdf.load(_write(tmp_path, joints, "<link name='a'/><link name='b'/><link name='c'/>"))


def test_every_moving_joint_needs_a_variable():
    robot = urdf.load(urdf.description(ROBOTS[0]))
    with pytest.raises(SpecError, match="missing \\['panda_finger_joint2'\\]"):
        urdf.Kinematics(robot, {j.name: se.Symbol(f"q{k}") for k, j in enumerate(robot.moving_joints[:-1])})
