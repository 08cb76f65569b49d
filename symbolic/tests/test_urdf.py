"""The URDF front end against independent truths: every link's pose and frame Jacobian
against Pinocchio reading the same files at 10^4 random configurations within the joint
limits, to 1e-12; the joint limits as Pinocchio reads them; every fitted collision box
against the mesh file's own vertices (read here, not by trimesh), in exact arithmetic;
the SRDF's pairs against Pinocchio's tree; and a broken URDF is a SpecError naming the
element."""

from __future__ import annotations

import dataclasses
import math
import struct
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path

import numpy as np
import pinocchio as pin  # `pin` on PyPI: symbolic/requirements-test.txt (robots: requirements-urdf.txt)
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


def _pinocchio_q(model, names, values) -> np.ndarray:
    """Pinocchio's configuration vector for joint ``names`` at ``values`` (a continuous
    joint is stored as (cos, sin))."""
    q_pin = np.zeros(model.nq)
    for name, v in zip(names, values, strict=True):
        joint = model.joints[model.getJointId(name)]
        q_pin[joint.idx_q:joint.idx_q + joint.nq] = (math.cos(v), math.sin(v)) if joint.nq == 2 else v
    return q_pin


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
        pin.framesForwardKinematics(model, data, _pinocchio_q(model, q, values))
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


# ------------------------------------------------------------------ frame Jacobians


def _vee(m) -> list:
    return [m[2][1], m[0][2], m[1][0]]


@pytest.mark.parametrize("relative", ["panda_description/urdf/panda.urdf",
                                      "anymal_c_simple_description/urdf/anymal.urdf"])
def test_every_link_jacobian_matches_pinocchio(relative):
    # The frame Jacobian of each link, by differentiating the symbolic pose: the origin's
    # velocity dp/dq and the angular velocity vee(dR/dq_j R^T), both in the root frame;
    # Pinocchio's getFrameJacobian in LOCAL_WORLD_ALIGNED is the same pair.
    path = urdf.description(relative)
    robot = urdf.load(path)
    q = {j.name: se.Symbol(f"q_{k}") for k, j in enumerate(robot.moving_joints)}
    fk = urdf.Kinematics(robot, q)
    flat = []
    for link in robot.links:
        r, p = fk.pose(link)
        for v in q.values():
            dr = [[se.diff(r[i][j], v) for j in range(3)] for i in range(3)]
            omega = _vee([[se.Add(*[dr[i][k] * r[j][k] for k in range(3)]) for j in range(3)] for i in range(3)])
            flat += [se.diff(e, v) for e in p] + omega
    ours = se.Lambdify(list(q.values()), flat, cse=True)
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    frames = [model.getFrameId(link, pin.FrameType.BODY) for link in robot.links]
    columns = [model.joints[model.getJointId(name)].idx_v for name in q]
    rng = np.random.default_rng(351)
    worst = 0.0
    for values in _random_configurations(robot, rng):
        pin.computeJointJacobians(model, data, _pinocchio_q(model, q, values))
        pin.updateFramePlacements(model, data)
        got = np.asarray(ours(values)).reshape(len(robot.links), len(q), 6)
        for k, f in enumerate(frames):
            want = pin.getFrameJacobian(model, data, f, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:, columns].T
            worst = max(worst, float(np.max(np.abs(got[k] - want))))
    assert worst <= 1e-12, f"{relative}: largest Jacobian difference {worst:.3g}"


@pytest.mark.parametrize("relative", ["panda_description/urdf/panda.urdf",
                                      "anymal_c_simple_description/urdf/anymal.urdf"])
def test_the_front_ends_jacobians_are_pinocchios(relative):
    # Kinematics.jacobian, from the joints' axes and origins (not by differentiating),
    # for every link's origin and for a point 10 cm off it in each axis, against
    # Pinocchio's LOCAL_WORLD_ALIGNED frame Jacobian (shifted to the point: v + w x r).
    path = urdf.description(relative)
    robot = urdf.load(path)
    q = {j.name: se.Symbol(f"q_{k}") for k, j in enumerate(robot.moving_joints)}
    fk = urdf.Kinematics(robot, q)
    offset = (0.1, -0.1, 0.1)
    flat = []
    for link in robot.links:
        for point in (None, offset):
            linear, angular = fk.jacobian(link, list(q.values()), point)
            flat += [e for row in linear + angular for e in row]
    ours = se.Lambdify(list(q.values()), flat, cse=True)
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    frames = [model.getFrameId(link, pin.FrameType.BODY) for link in robot.links]
    columns = [model.joints[model.getJointId(name)].idx_v for name in q]
    rng = np.random.default_rng(352)
    worst = 0.0
    for values in _random_configurations(robot, rng):
        pin.computeJointJacobians(model, data, _pinocchio_q(model, q, values))
        pin.updateFramePlacements(model, data)
        got = np.asarray(ours(values)).reshape(len(robot.links), 2, 6, len(q))
        # Every frame at once: (frame, 6, joint) Jacobians and (frame, 3) arms.
        origin = np.stack([pin.getFrameJacobian(model, data, f, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:, columns]
                           for f in frames])
        arm = np.stack([data.oMf[f].rotation @ np.array(offset) for f in frames])
        shifted = origin.copy()
        shifted[:, :3] += np.cross(origin[:, 3:], arm[:, :, None], axis=1)
        worst = max(worst, float(np.max(np.abs(got[:, 0] - origin))), float(np.max(np.abs(got[:, 1] - shifted))))
    assert worst <= 1e-12, f"{relative}: largest Jacobian difference {worst:.3g}"

def test_limits_are_the_urdfs_as_pinocchio_reads_them():
    path = urdf.description("panda_description/urdf/panda.urdf")
    robot = urdf.load(path)
    model = pin.buildModelFromUrdf(str(path))
    names = [f"panda_joint{i}" for i in range(1, 8)]
    idx = [model.joints[model.getJointId(n)].idx_q for n in names]
    assert robot.limits(names, "position") == list(zip(model.lowerPositionLimit[idx],
                                                       model.upperPositionLimit[idx], strict=True))
    assert [v for _, v in robot.limits(names, "velocity")] == list(model.velocityLimit[idx])
    assert [v for _, v in robot.limits(names, "effort")] == list(model.effortLimit[idx])
    with pytest.raises(SpecError, match="joint 'panda_joint1': no torque limit|limits kind 'torque'"):
        robot.limits(names, "torque")


# ------------------------------------------------------------------ collision geometry


def _read_stl(path: Path) -> list[tuple[float, float, float]]:
    """The vertices of an STL file (binary or ASCII), read here without trimesh: the
    fitted boxes are checked against the file itself."""
    data = path.read_bytes()
    if data[:5] == b"solid" and b"facet" in data[:1000]:
        return [tuple(float(v) for v in line.split()[1:4]) for line in data.decode().splitlines()
                if line.strip().startswith("vertex")]
    count = struct.unpack_from("<I", data, 80)[0]
    assert len(data) == 84 + 50 * count, f"{path}: not a binary STL"
    return [struct.unpack_from("<3f", data, 84 + 50 * t + 12 + 12 * k) for t in range(count) for k in range(3)]


def _rpy(rpy) -> list[list[Fraction]]:
    return [[Fraction(float(v)) for v in row] for row in urdf.rpy_matrix(rpy)]


def _element_points(c: urdf.Collision) -> tuple[np.ndarray, Callable[[int], tuple[Fraction, ...]]]:
    """Points whose hull holds the element, in the link frame: the mesh file's vertices,
    or the corners of the box around the primitive; as floats, and each exactly."""
    if c.kind == "mesh":
        assert c.mesh.suffix.lower() == ".stl", c.mesh
        local = np.array(_read_stl(c.mesh), dtype=float)
        scale = [Fraction(v) for v in c.size]
    else:
        local = np.array([(sx, sy, sz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        if c.kind == "box":
            scale = [Fraction(v) / 2 for v in c.size]
        elif c.kind == "sphere":
            scale = [Fraction(c.size[0])] * 3
        else:
            r, length = (Fraction(v) for v in c.size)
            scale = [r, r, length / 2 + (r if c.kind == "capsule" else 0)]
    rot, shift = _rpy(c.rpy), [Fraction(v) for v in c.xyz]

    def exact(i: int) -> tuple[Fraction, ...]:
        v = [Fraction(float(local[i][k])) * scale[k] for k in range(3)]
        return tuple(sum(rot[a][k] * v[k] for k in range(3)) + shift[a] for a in range(3))

    floats = (local * np.array([float(v) for v in scale])) @ np.array([[float(v) for v in row] for row in rot]).T
    return floats + np.array([float(v) for v in shift]), exact


def _axis_slacks(box: urdf.FittedBox, elements) -> list[Fraction]:
    """Per box axis, the smallest distance from any point to that pair of faces (< 0: a
    point is outside), exactly. Floating point picks the points within 1e-9 m of the
    smallest (its error is below 1e-12 m at these sizes); rationals decide among them."""
    c = [Fraction(v) for v in box.center]
    r = [[Fraction(v) for v in row] for row in box.rotation]
    out = []
    for a in range(3):
        best = None
        for floats, exact in elements:
            assert np.all(np.abs(floats) < 1e3)
            slack = box.half[a] - np.abs((floats - np.array(box.center)) @ np.array(box.rotation)[:, a])
            for i in np.flatnonzero(slack <= slack.min() + 1e-9):
                p = exact(int(i))
                value = Fraction(box.half[a]) - abs(sum(r[k][a] * (p[k] - c[k]) for k in range(3)))
                best = value if best is None else min(best, value)
        out.append(best)
    return out


DESCRIPTIONS = ["panda_description/urdf/panda.urdf", "anymal_c_simple_description/urdf/anymal.urdf",
                "solo_description/robots/solo12.urdf", "ur_description/urdf/ur5_robot.urdf"]


@pytest.mark.parametrize("relative", DESCRIPTIONS)
def test_every_fitted_box_contains_its_links_geometry_exactly(relative):
    robot = urdf.load(urdf.description(relative))
    meshes = [c for c in robot.collisions if c.kind == "mesh" and c.mesh.suffix.lower() != ".stl"]
    if meshes:
        pytest.skip(f"{relative}: meshes other than STL ({meshes[0].mesh.suffix}) are not read by this test")
    links = [link for link in robot.links if robot.collision(link)]
    assert links, relative
    for link in links:
        box = urdf.link_box(robot, link)
        slacks = _axis_slacks(box, [_element_points(c) for c in robot.collision(link)])
        need = 0 if box.exact else Fraction(urdf.FIT_MARGIN)
        assert min(slacks) >= need, f"{link}: a point {float(-min(slacks))} m outside"
        # Tight: each pair of faces touches the geometry to within the rounding (the
        # margin and two quanta).
        assert max(slacks) <= (0 if box.exact else 4 * Fraction(urdf.FIT_QUANTUM)), f"{link}: loose {slacks}"
        assert all(h > 0 for h in box.half)
        # The check can fail: the same box a fraction of a micrometre smaller leaves a point out.
        smaller = dataclasses.replace(box, half=tuple(h - 3 * urdf.FIT_QUANTUM for h in box.half))
        assert min(_axis_slacks(smaller, [_element_points(c) for c in robot.collision(link)])) < 0
        r = np.array(box.rotation)
        assert np.allclose(r @ r.T, np.eye(3), atol=1e-15) and np.linalg.det(r) > 0, f"{link}: not a rotation"
        for shape, c in zip(urdf.collision_shapes(robot, link), robot.collision(link), strict=True):
            if isinstance(shape, urdf.FittedBox) and not shape.exact:
                assert min(_axis_slacks(shape, [_element_points(c)])) >= Fraction(urdf.FIT_MARGIN)


def test_urdf_boxes_and_spheres_are_reproduced_exactly():
    robot = urdf.load(urdf.description("anymal_c_simple_description/urdf/anymal.urdf"))
    kinds = {"box": 0, "sphere": 0}
    for link in robot.links:
        for shape, c in zip(urdf.collision_shapes(robot, link), robot.collision(link), strict=True):
            if c.kind == "box":
                assert shape.exact and shape.center == c.xyz and shape.half == tuple(v / 2 for v in c.size)
                assert shape.rotation == tuple(tuple(float(v) for v in row) for row in urdf.rpy_matrix(c.rpy))
            elif c.kind == "sphere":
                assert isinstance(shape, urdf.Sphere) and shape.center == c.xyz and shape.radius == c.size[0]
            else:
                continue
            kinds[c.kind] += 1
    assert kinds["box"] >= 10 and kinds["sphere"] == 4, kinds


def test_the_srdf_pairs_are_the_non_adjacent_pairs_it_does_not_disable():
    robot = urdf.load(urdf.description("panda_description/urdf/panda.urdf"))
    srdf = urdf.load_srdf(urdf.description("panda_description/srdf/panda.srdf"), robot)
    assert len(srdf.disabled) == 35
    pairs = urdf.self_collision_pairs(robot, srdf)
    # 11 links with geometry make 55 pairs; the SRDF disables 35, and every pair it leaves
    # is at least two moving joints apart (Pinocchio's tree, counted here).
    assert len(pairs) == 20
    model = pin.buildModelFromUrdf(str(urdf.description("panda_description/urdf/panda.urdf")))

    def joint_chain(link):
        j = model.frames[model.getFrameId(link)].parentJoint
        chain = []
        while j > 0:
            chain.append(j)
            j = model.parents[j]
        return set(chain)

    for a, b in pairs:
        assert frozenset((a, b)) not in srdf.disabled
        assert len(joint_chain(a) ^ joint_chain(b)) >= 2, (a, b)


def test_a_pair_overlapping_at_the_reference_is_named():
    robot = urdf.load(urdf.description("panda_description/urdf/panda.urdf"))
    srdf = urdf.load_srdf(urdf.description("panda_description/srdf/panda.srdf"), robot)
    links = [link for link in robot.links if robot.collision(link)]
    boxes = {link: urdf.link_box(robot, link) for link in links}
    pairs = urdf.self_collision_pairs(robot, srdf, links)
    folded = dict(zip([f"panda_joint{i}" for i in range(1, 8)], [-0.7, 0.64, -0.74, -3.0, 0.49, 1.12, 1.55],
                      strict=True))
    q = {**folded, "panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    with pytest.raises(SpecError, match=r"at the fold, these self-collision pairs' boxes overlap: .*"
                                        r"panda_link1/panda_link7 \("):
        urdf.require_clear(robot, pairs, boxes, q, "the fold")
    # ... and the same pairs at the SRDF's default state are clear.
    urdf.require_clear(robot, pairs, boxes, {**srdf.states["default"], "panda_finger_joint2": 0.001}, "default")


def test_a_floating_base_srdf_keeps_its_virtual_joint_apart_from_the_urdf_joints():
    # ANYmal's SRDF names its free flyer (Pinocchio's root_joint) in its groups and gives
    # it x y z qx qy qz qw in its standing state; the URDF has no such joint.
    robot = urdf.load(urdf.description("anymal_c_simple_description/urdf/anymal.urdf"))
    srdf = urdf.load_srdf(urdf.description("anymal_c_simple_description/srdf/anymal.srdf"), robot)
    assert srdf.virtual_joints == {"root_joint": "floating"}
    assert srdf.virtual_states["standing"] == {"root_joint": (0.0, 0.0, 0.528, 0.0, 0.0, 0.0, 1.0)}
    assert sorted(srdf.states["standing"]) == sorted(j.name for j in robot.moving_joints)
    assert len(srdf.disabled) == 270


@pytest.mark.parametrize("body, message", [
    ("<virtual_joint name='world' type='spherical' parent_frame='w' child_link='a'/>",
     "virtual_joint 'world' has type 'spherical'"),
    ("<virtual_joint name='world' type='floating' parent_frame='w' child_link='a'/>"
     "<group_state name='s' group='g'><joint name='world' value='0 0 1'/></group_state>",
     "group_state 's', joint 'world': '0 0 1' must be 7 finite numbers"),
    ("<group_state name='s' group='g'><joint name='nowhere' value='0'/></group_state>", "no joint 'nowhere'"),
])
def test_a_broken_srdf_names_the_element(tmp_path, body, message):
    robot = urdf.load(_write(tmp_path, _joint("j1", "a", "b") + _joint("j2", "b", "c")))
    path = tmp_path / "broken.srdf"
    path.write_text(f"<robot name='r'>{body}</robot>")
    with pytest.raises(SpecError) as err:
        urdf.load_srdf(path, robot)
    assert message in str(err.value), str(err.value)


@pytest.mark.parametrize("collision, message", [
    ("<geometry><mesh filename='nowhere.stl'/></geometry>", "link 'b', collision: mesh 'nowhere.stl' is missing"),
    ("<geometry><cone radius='1'/></geometry>", "link 'b', collision: the geometry must be one of"),
    ("<geometry><box size='1 -1 1'/></geometry>", "link 'b', collision: box size (1.0, -1.0, 1.0) must be > 0"),
    ("<geometry><sphere/></geometry>", "link 'b', collision: sphere has no radius"),
    ("<geometry><cylinder radius='0.1' length='nan'/></geometry>", "cylinder length: 'nan' must be 1 finite"),
])
def test_broken_collision_geometry_names_the_link(tmp_path, collision, message):
    links = f"<link name='a'/><link name='b'><collision>{collision}</collision></link><link name='c'/>"
    with pytest.raises(SpecError) as err:
        urdf.load(_write(tmp_path, _joint("j1", "a", "b") + _joint("j2", "b", "c"), links))
    assert message in str(err.value) and "broken.urdf" in str(err.value)


def test_a_floating_base_places_every_link_in_the_world_as_pinocchio_does():
    # ANYmal C on a free flyer: the trunk's pose from roll, pitch, yaw and a position, the
    # legs' joints on top; every link's world pose against Pinocchio's JointModelFreeFlyer
    # model (its base orientation as the quaternion of the same rotation).
    path = urdf.description("anymal_c_simple_description/urdf/anymal.urdf")
    robot = urdf.load(path)
    q = {j.name: se.Symbol(f"q_{k}") for k, j in enumerate(robot.moving_joints)}
    base = se.symbols("px py pz roll pitch yaw")
    fk = urdf.Kinematics(robot, q, root_pose=(urdf.euler_zyx(*base[3:]), list(base[:3])))
    flat = [e for link in robot.links for r, p in [fk.pose(link)] for e in [*sum(r, []), *p]]
    ours = se.Lambdify(list(base) + list(q.values()), flat, cse=True)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    data = model.createData()
    frames = [model.getFrameId(link, pin.FrameType.BODY) for link in robot.links]
    rng = np.random.default_rng(355)
    worst = 0.0
    for joints in _random_configurations(robot, rng)[:2000]:
        pose = np.concatenate([rng.uniform(-2, 2, 3), rng.uniform(-np.pi, np.pi, 3) * [1, 0.45, 1]])
        rotation = np.asarray(se.Lambdify(base[3:], sum(urdf.euler_zyx(*base[3:]), []))(pose[3:])).reshape(3, 3)
        q_pin = np.zeros(model.nq)
        q_pin[:3] = pose[:3]
        q_pin[3:7] = pin.Quaternion(rotation).coeffs()  # x, y, z, w
        for name, v in zip(q, joints, strict=True):
            q_pin[model.joints[model.getJointId(name)].idx_q] = v
        pin.framesForwardKinematics(model, data, q_pin)
        got = np.asarray(ours(np.concatenate([pose, joints]))).reshape(len(robot.links), 12)
        for k, f in enumerate(frames):
            placement = data.oMf[f]
            want = np.concatenate([placement.rotation.ravel(), placement.translation])
            worst = max(worst, float(np.max(np.abs(got[k] - want))))
    assert worst <= 1e-12, f"largest pose difference {worst:.3g}"


def test_root_pose_and_another_base_do_not_mix():
    robot = urdf.load(urdf.description("anymal_c_simple_description/urdf/anymal.urdf"))
    q = {j.name: 0.0 for j in robot.moving_joints}
    with pytest.raises(SpecError, match="root_pose places the root link"):
        urdf.Kinematics(robot, q, base="LF_HIP", root_pose=(urdf.euler_zyx(0, 0, 0), [0, 0, 0]))
    with pytest.raises(SpecError, match="root_pose is"):
        urdf.Kinematics(robot, q, root_pose=([[1, 0, 0]], [0, 0, 0]))


def test_a_fitted_box_is_kept_between_generations(tmp_path, monkeypatch):
    # Fitted once, read back equal without touching the mesh; a changed mesh (or the cache
    # off) fits again.
    monkeypatch.setenv("CBFGEN_SYMBOLIC_CACHE", str(tmp_path / "cache"))
    robot = urdf.load(urdf.description("panda_description/urdf/panda.urdf"))
    fitted = urdf.link_box(robot, "panda_link3")
    assert len(list((tmp_path / "cache" / "boxes").iterdir())) == 1
    fit_box = urdf.fit_box

    def refuse(*args):
        raise AssertionError("fitted again")

    monkeypatch.setattr(urdf, "fit_box", refuse)
    assert urdf.link_box(robot, "panda_link3") == fitted
    monkeypatch.setenv("CBFGEN_SYMBOLIC_CACHE", "off")
    with pytest.raises(AssertionError, match="fitted again"):
        urdf.link_box(robot, "panda_link3")
    # The mesh's bytes are the key, not its path: a copy elsewhere is kept; a copy whose
    # bytes differ (a binary STL's free 80-byte header) is fitted again.
    monkeypatch.setenv("CBFGEN_SYMBOLIC_CACHE", str(tmp_path / "cache"))
    (element,) = robot.collision("panda_link3")
    data = element.mesh.read_bytes()
    assert not data.startswith(b"solid")  # binary: bytes 0-79 are a header no reader interprets

    def with_mesh(name: str, content: bytes):
        copy = tmp_path / name
        copy.write_bytes(content)
        return dataclasses.replace(robot, collisions=tuple(dataclasses.replace(c, mesh=copy) if c == element else c
                                                           for c in robot.collisions))

    assert urdf.link_box(with_mesh("same.stl", data), "panda_link3") == fitted
    changed = with_mesh("changed.stl", b"X" + data[1:])
    with pytest.raises(AssertionError, match="fitted again"):
        urdf.link_box(changed, "panda_link3")
    monkeypatch.setattr(urdf, "fit_box", fit_box)
    assert urdf.link_box(changed, "panda_link3") == fitted
