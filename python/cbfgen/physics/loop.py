"""The filter on a physical Tachyon 3: MuJoCo's state in, joint targets out, at 1 kHz.

Each cycle:

1. **measure** — MuJoCo's body and wheel poses and velocities become the model's state
   ``x`` (:meth:`PhysicalRobot.measure`): body and toes relative to the ground-moving
   origin, whose own states (position, heading, speed) are the reference's, because the
   origin is the planner's frame and has no physical counterpart;
2. **plan and filter** — the gait's nominal input for ``x``, corrected by the ECBF-QP
   filter on ``x``: the filter sees the physical robot;
3. **integrate** — the reference state ``x_ref`` (the kinematic model the filter was
   built on) takes one Euler step with the filtered input;
4. **track** — the joint targets are ``x_ref``'s knee lengths and hip angles and their
   rates (the joint-limit kernels' quantities, :func:`cbfgen.tachyon3.leg_joints`), and
   each driven wheel's spin for its toe's ground speed (the middle wheels are passive
   and omnidirectional); MuJoCo steps 1 ms.

Before measuring, :meth:`cbfgen.tachyon3.Course.exchange_origin` moves the reference's
origin where the support puts it: onto the drive axle a turning swing turns about.

Because the gait and the filter act on the measured state while the servos chase the
reference, the gait's feedback on the physical error accumulates in the reference: the
legs carry the robot's weight (a stiff servo sags by a few millimetres, and the gait
raises the reference until the body is where it wants it), and a wheel that slips is
driven on until its toe catches up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import CbfError
from .. import tachyon3 as t3
from .model import TIMESTEP, RobotParams, robot_mjcf

try:
    import mujoco
except ImportError as missing:  # pragma: no cover - the message is the point
    raise ImportError(
        "cbfgen.physics needs MuJoCo's Python bindings: pip install -r python/requirements.txt "
        "(or scripts/cbf setup)"
    ) from missing

BODY_FAMILY = "body_edge"

PENETRATION_TOLERANCE = 0.001
"""Depth into a solid of the terrain that counts as penetration [m]: a wheel standing
on a tread touches it, and MuJoCo's soft contact lets it a little way in."""

RISER_ANGLE = np.radians(30.0)
"""A contact whose normal is more than this from vertical is a riser's (or a nosing met
from the front, or a side) rather than a tread's."""
_COS_RISER_ANGLE = float(np.cos(RISER_ANGLE))

MAX_CATCH_UP = 0.1
"""Most the reference's speed along the course may differ from the robot's [m/s]."""

TIP_OVER_ROLL = np.radians(45.0)
"""A measured roll beyond this ends a run as tipped over: the sagittal model cannot
represent the robot any more, and its state would read as an upright robot's."""

PHYSICAL_SCENARIOS = list(t3.SCENARIOS)
"""The courses the physical robot runs: all of them. The ``turn`` course's turn is the
paper's, on three legs about a drive axle, so no wheel has to steer (an earlier turn
on the spot on all six wheels scrubbed the driven wheels and tipped the robot over)."""


def check_physical_scenario(scenario: str) -> None:
    """Raise ``ValueError`` naming the courses, unless ``scenario`` is one of :data:`PHYSICAL_SCENARIOS`."""
    if scenario not in PHYSICAL_SCENARIOS:
        raise ValueError(f"the physical robot does not run {scenario!r}; one of {', '.join(PHYSICAL_SCENARIOS)}")


MAX_LEAD = 0.05
"""Furthest a wheel's angle target may run ahead of (or behind) the wheel, as rolled
distance [m]: enough to catch up a slip of a few centimetres, little against the 35 cm
of a tread, and no winding up of a wheel held by an obstacle."""


# The per-cycle code below runs a hundred thousand times a run on 3-vectors, where a numpy
# call costs more than its arithmetic: it hoists what is fixed out of the loop and works
# on Python floats where the operations are single IEEE products and sums (the same
# numbers either way). It keeps numpy's matrix products, solves, sums and sin, cos and
# arctan2 as they are: BLAS, numpy's pairwise sums and numpy's vectorised functions (on
# AVX-512) round differently from the same formulas written out, and the closed loop
# would drift from its recorded runs.


def _rot_z(yaw: float) -> np.ndarray:
    c, s = float(np.cos(yaw)), float(np.sin(yaw))  # numpy's numbers; floats build the array faster
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x(angle: float) -> np.ndarray:
    c, s = float(np.cos(angle)), float(np.sin(angle))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _cross(a, b) -> tuple[float, float, float]:
    """a × b of two 3-vectors of Python floats."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _set_quat(quat: np.ndarray, rotation: np.ndarray) -> None:
    """Write ``rotation``'s quaternion into ``quat`` (a view into ``qpos``, say)."""
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation).ravel())


_YAW_AXIS = (0.0, 0.0, 1.0)
_BODY = mujoco.mjtObj.mjOBJ_BODY

_POINT_POSITIONS = np.array([[6, *range(12, 36, 4)], [7, *range(13, 36, 4)]])
"""The state's sagittal points, the body centre and the six toes: the indices of their x
(first row) and z (second row)."""
_POINT_VELOCITIES = np.array([[9, *range(14, 36, 4)], [10, *range(15, 36, 4)]])
"""The indices of the same points' x and z velocities."""
_POINT_STATES = np.array([_POINT_POSITIONS, _POINT_VELOCITIES])
_POINTS = _POINT_POSITIONS.shape[1]
_Z_DOWN = np.array([[1.0], [-1.0]])  # (r_z, r_x) reversed from (r_x, r_z) times this: (r_z, -r_x)
_RIGID_RATES = np.zeros((2 * _POINTS + 1, 3))
"""The least-squares rows of :func:`anchored`'s rigid rates (vx, vz, spin) over the
points' x and z velocities and the pitch rate, less the spin's column above the last
row (each point's offset from the centroid): vx moves every x, vz every z."""
_RIGID_RATES[:_POINTS, 0] = _RIGID_RATES[_POINTS:-1, 1] = _RIGID_RATES[-1, 2] = 1.0


class PhysicalRobot:
    """Tachyon 3 in MuJoCo on one course's true terrain: pose it from a model state,
    read its state back, drive its servos from a reference state."""

    def __init__(self, course: t3.Course, params: RobotParams | None = None) -> None:
        params = RobotParams() if params is None else params
        self.params = params
        self.model = mujoco.MjModel.from_xml_string(robot_mjcf(course, params))
        self.data = mujoco.MjData(self.model)
        m = self.model
        name = mujoco.mj_name2id
        self.body = name(m, mujoco.mjtObj.mjOBJ_BODY, "body")
        self.body_geom = name(m, mujoco.mjtObj.mjOBJ_GEOM, "body")
        self.wheels = [name(m, mujoco.mjtObj.mjOBJ_BODY, f"{leg}_wheel") for leg in t3.LEG_NAMES]
        self.toe_geoms = [name(m, mujoco.mjtObj.mjOBJ_GEOM, f"{leg}_toe") for leg in t3.LEG_NAMES]
        # Geom id -> leg, -1 for every other geom: contacts are classified in one lookup.
        self._leg_of_geom = [-1] * m.ngeom
        for leg, geom in enumerate(self.toe_geoms):
            self._leg_of_geom[geom] = leg
        geom_names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(m.ngeom)]
        self.terrain_geoms = [g for g, n in enumerate(geom_names) if n.startswith("terrain")]
        # The solids as (centre, rotation, half extents), for the wheels' exact distances.
        self.solids = [(np.asarray(c), np.asarray(r), np.asarray(h)) for c, r, h in course.terrain_boxes()]
        # The same, stacked: the per-cycle measures run on every solid at once.
        self._solid_centers = np.array([c for c, _, _ in self.solids])
        self._solid_rotations = np.array([r for _, r, _ in self.solids])
        self._solid_halves = np.array([h for _, _, h in self.solids])
        self.solid_tops = self._solid_centers[:, 2] + self._solid_halves[:, 2]

        def joint(kind: str) -> tuple[list[int], list[int]]:
            ids = [name(m, mujoco.mjtObj.mjOBJ_JOINT, f"{leg}_{kind}") for leg in t3.LEG_NAMES]
            return [int(m.jnt_qposadr[j]) for j in ids], [int(m.jnt_dofadr[j]) for j in ids]

        (self.hip_q, self.hip_v), (self.knee_q, self.knee_v) = joint("hip"), joint("knee")
        # Only the driven wheels have a hinge and servos; the middle ones roll freely.
        self.drive = list(t3.DRIVE_LEGS)
        drive_names = [t3.LEG_NAMES[leg] for leg in self.drive]
        self.wheel_q = [int(m.jnt_qposadr[name(m, mujoco.mjtObj.mjOBJ_JOINT, f"{n}_wheel")]) for n in drive_names]

        def actuator(suffix: str, legs: list[str] = t3.LEG_NAMES) -> list[int]:
            return [name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{leg}_{suffix}") for leg in legs]

        self.hip_pos, self.hip_vel = actuator("hip_pos"), actuator("hip_vel")
        self.knee_pos, self.knee_vel = actuator("knee_pos"), actuator("knee_vel")
        self.wheel_pos, self.wheel_vel = actuator("wheel_pos", drive_names), actuator("wheel_vel", drive_names)
        self.outward = np.asarray(t3.HIP_OUTWARD)
        self._outward = self.outward.tolist()
        # The per-cycle code's index arrays: servo targets by joint quantity (the columns
        # of leg_joints: knee length, hip angle, their rates), and the bodies measure()
        # reads, the body first and then the wheels.
        self._joint_servos = np.array([self.knee_pos, self.hip_pos, self.knee_vel, self.hip_vel])
        self._wheel_q = np.array(self.wheel_q)
        self._wheel_pos, self._wheel_vel = np.array(self.wheel_pos), np.array(self.wheel_vel)
        self._wheels = np.array(self.wheels)
        self._measured_bodies = np.array([self.body, *self.wheels])
        self._velocities = np.zeros((len(self._measured_bodies), 6))
        self._fromto = np.zeros(6)  # mj_geomDistance's segment, unread
        # The robot with its roll taken out, posed by measure() each cycle.
        self.upright = mujoco.MjData(m)

    def pose(self, x: np.ndarray) -> None:
        """Place the robot at model state ``x``, at rest relative to it."""
        d = self.data
        center, rotation, _ = t3.world_kinematics(x)
        d.qpos[:] = self.model.qpos0  # the ball joints' identity quaternions
        d.qvel[:] = 0.0
        d.qpos[0:3] = center
        _set_quat(d.qpos[3:7], rotation)
        joints = t3.leg_joints(x)
        d.qpos[self.knee_q] = joints[:, 0]
        d.qpos[self.hip_q] = joints[:, 1]
        self.wheel_target = d.qpos[self.wheel_q].copy()
        self.command(x)
        mujoco.mj_forward(self.model, d)

    def _pose_upright(self) -> float:
        """Pose :attr:`upright` as the robot with its roll taken out: the same body
        centre, heading and pitch, every joint and joint rate the same, and the body's
        rate of roll removed from its angular velocity. Returns the roll [rad]."""
        d, u = self.data, self.upright
        rotation = d.xmat[self.body].reshape(3, 3)
        # rotation = Rz(yaw) Ry(pitch) Rx(roll): roll is about the body's own x axis.
        roll = float(np.arctan2(rotation[2, 1], rotation[2, 2]))
        upright = rotation @ _rot_x(-roll)
        # The angular velocity as yaw, pitch and roll rates about their own axes; the
        # upright body turns at the first two.
        yaw = np.arctan2(upright[1, 0], upright[0, 0])
        pitch_axis = (float(-np.sin(yaw)), float(np.cos(yaw)), 0.0)  # Rz(yaw)'s y axis
        omega = rotation @ d.qvel[3:6]
        axes = np.array([_YAW_AXIS, pitch_axis, upright[:, 0].tolist()]).T
        yaw_rate, pitch_rate, _ = np.linalg.solve(axes, omega).tolist()
        u.qpos[:] = d.qpos
        u.qvel[:] = d.qvel
        _set_quat(u.qpos[3:7], upright)
        turning = [yaw_rate * z + pitch_rate * p for z, p in zip(_YAW_AXIS, pitch_axis, strict=True)]
        u.qvel[3:6] = upright.T @ np.array(turning)
        # What measure() reads (poses and body velocities), and nothing of mj_forward's
        # contacts, mass matrix and forces.
        mujoco.mj_kinematics(self.model, u)
        mujoco.mj_comPos(self.model, u)
        mujoco.mj_comVel(self.model, u)
        return roll

    def measure(self, reference: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
        """The model state of the physical robot: its joints on the upright robot
        (:meth:`_pose_upright`), as the model holds no roll, relative to an origin at
        ``reference``'s position and speeds with the body's measured heading (the model's
        body faces along its origin); and what the model cannot hold (lateral offset,
        roll) and the heading's error from ``reference``'s as a dict."""
        x = np.array(reference, dtype=float)
        roll = self._pose_upright()
        u = self.upright
        upright = u.xmat[self.body].reshape(3, 3)
        # The heading's error wrapped into (-pi, pi]: np.angle, without its wrapper.
        error_turn = np.exp(1j * (np.arctan2(upright[1, 0], upright[0, 0]) - x[3]))
        heading_error = float(np.arctan2(error_turn.imag, error_turn.real))
        x[3] += heading_error
        origin = x[0:3]
        yaw, speed, yaw_rate = x[3], float(x[4]), float(x[5])
        heading = _rot_z(yaw)
        to_origin = heading.T
        origin_velocity = heading @ np.array([speed, 0.0, 0.0])
        spin = (0.0, 0.0, yaw_rate)

        # The model holds no roll, so it reads the robot's joints on the upright robot: a
        # knee lengthened under one side shows as that toe lower, where the gait and
        # the filter act on it. Read from where the wheels are, the toes of a rolled
        # robot standing on one tread look level, and what the gait pushes on them
        # winds up unseen in the reference as the roll itself.
        # Each body's position and velocity relative to the origin (body, wheels...), and
        # the body's angular velocity, in the origin's frame: one matrix-vector product
        # per vector, as a stack (the same BLAS call for each).
        bodies, velocities = self._measured_bodies, self._velocities
        for row, body in zip(velocities, bodies.tolist(), strict=True):
            mujoco.mj_objectVelocity(self.model, u, _BODY, body, row, 0)
        vectors = np.concatenate((u.xpos[bodies] - origin, velocities[:, 3:] - origin_velocity, velocities[:1, :3]))
        in_origin = np.matmul(to_origin, vectors[:, :, None])[:, :, 0].tolist()
        count = len(bodies)
        positions, moving, pitch_rate = in_origin[:count], in_origin[count:-1], in_origin[-1][1]
        # (x, z, vx, vz) of each point in the origin's frame, which turns at the yaw rate.
        points = []
        for position, velocity in zip(positions, moving, strict=True):
            turning = _cross(spin, position)
            points.append((position[0], position[2], velocity[0] - turning[0], velocity[2] - turning[2]))
        body_in_origin = to_origin @ upright
        pitch = float(np.arctan2(body_in_origin[0, 2], body_in_origin[0, 0]))
        (body_x, body_z, body_vx, body_vz), *toes = points
        x[6:] = [body_x, body_z, pitch, body_vx, body_vz, pitch_rate, *(value for toe in toes for value in toe)]
        off_model = {"lateral": positions[0][1], "roll": roll, "heading": heading_error}
        return x, off_model

    def command(self, reference: np.ndarray) -> None:
        """Servo targets for reference state ``reference``: hips and knees to its joint
        positions and rates, each wheel to roll at its toe's ground speed."""
        d = self.data
        joints = t3.leg_joints(reference)
        d.ctrl[self._joint_servos] = joints.T
        speed, yaw_rate, pitch_rate = reference[[4, 5, 11]].tolist()
        # Each toe's offset across the heading, where the yaw rate moves it along.
        _, _, toes = t3.world_kinematics(reference)
        across = ((toes[:, :2] - reference[0:2]) @ _rot_z(reference[3])[:2, 1]).tolist()
        toe_vx, hip_rate, outward = reference[14::4].tolist(), joints[:, 3].tolist(), self._outward
        ground_speed = [speed - yaw_rate * across[leg] + toe_vx[leg] for leg in self.drive]
        # A hinge about (0, -outward, 0) turns the shin about +y at -outward times its rate.
        shin_spin = [pitch_rate - outward[leg] * hip_rate[leg] for leg in self.drive]
        spin = np.array([v / t3.TOE_RADIUS - s for v, s in zip(ground_speed, shin_spin, strict=True)])
        # The angle target runs on with the spin, at most MAX_LEAD of rolling ahead of
        # (or behind) the wheel: a wheel held by an obstacle is not wound up.
        reach = MAX_LEAD / t3.TOE_RADIUS
        angle = d.qpos[self._wheel_q]
        self.wheel_target = (self.wheel_target + spin * TIMESTEP).clip(angle - reach, angle + reach)
        d.ctrl[self._wheel_pos] = self.wheel_target
        d.ctrl[self._wheel_vel] = spin

    def step(self) -> None:
        mujoco.mj_step(self.model, self.data)

    def contacts(self) -> tuple[bool, int]:
        """(the body touches the terrain, toes touching a riser or an edge: a contact whose
        normal is more than :data:`RISER_ANGLE` from vertical)."""
        body_contact, risers, _ = self._scan_contacts()
        return body_contact, risers

    def _scan_contacts(self) -> tuple[bool, int, dict[int, int]]:
        """One pass over MuJoCo's active contacts: :meth:`contacts`, and each touching
        wheel's leg with the index of its last contact."""
        contact = self.data.contact  # MuJoCo's active contacts, one array per field
        geom1, geom2 = contact.geom1.tolist(), contact.geom2.tolist()
        body_geom, leg_of_geom = self.body_geom, self._leg_of_geom
        body_contact, risers, touching = False, 0, {}
        for c, (g1, g2, normal_z) in enumerate(zip(geom1, geom2, contact.frame[:, 2].tolist(), strict=True)):
            legs = leg_of_geom[g1], leg_of_geom[g2]
            if g1 == body_geom or g2 == body_geom:
                body_contact = True
            elif (legs[0] >= 0 or legs[1] >= 0) and abs(normal_z) < _COS_RISER_ANGLE:
                risers += 1
            for leg in legs:
                if leg >= 0:
                    touching[leg] = c
        return body_contact, risers, touching

    def ground_under(self, point: np.ndarray) -> float:
        """The top of the highest solid under ``point`` (x, y) [m]: the true ground (the
        course's floor height is what it perceives); 0 off every solid."""
        return float(self.grounds_under(np.asarray(point)[None])[0])

    def grounds_under(self, points: np.ndarray) -> np.ndarray:
        """:meth:`ground_under` each of ``points`` (n, 2 or more) at once."""
        offset = points[:, None, :2] - self._solid_centers[:, :2]
        local = np.einsum("sji,nsj->nsi", self._solid_rotations[:, :2, :2], offset)
        under = np.all(np.abs(local) <= self._solid_halves[:, :2], axis=2)
        return np.where(under, self.solid_tops, -np.inf).max(axis=1, initial=0.0)

    def body_distance(self) -> float:
        """MuJoCo's signed distance between the body box and the nearest terrain box [m]
        (negative: penetration), up to 1 m."""
        m, d, body, fromto = self.model, self.data, self.body_geom, self._fromto
        return min([mujoco.mj_geomDistance(m, d, body, g, 1.0, fromto) for g in self.terrain_geoms])

    def wheel_centers(self) -> np.ndarray:
        """MuJoCo's wheel centres now, (wheel, 3), a copy."""
        return self.data.xpos[self._wheels]

    def wheel_distances(self, centers: np.ndarray | None = None) -> tuple[float, float] | np.ndarray:
        """(nearest wheel to a solid of the terrain, nearest wheel to a riser) [m] by exact
        sphere–box distance from MuJoCo's wheel centres: the gap, or minus the depth.
        A riser is where the normal from the solid's nearest point to the wheel's centre
        (or, for a centre inside, the face it is least deep under) is more than
        :data:`RISER_ANGLE` from vertical, as :meth:`contacts` reads MuJoCo's normals.

        With ``centers`` (…, wheel, 3) of :meth:`wheel_centers`, the same for each set of
        centres at once, as an array (…, 2)."""
        if centers is None:
            return tuple(self.wheel_distances(self.wheel_centers()).tolist())
        rotations, halves = self._solid_rotations, self._solid_halves
        # Each wheel centre in each solid's frame: (…, wheel, solid, 3).
        local = np.einsum("sji,...wsj->...wsi", rotations, centers[..., None, :] - self._solid_centers)
        outward = local - np.clip(local, -halves, halves)
        # Outside: the gap from the nearest point, and the normal the offset from it.
        gap = np.linalg.norm(outward, axis=-1)
        distance, normal, normal_length = gap - t3.TOE_RADIUS, outward, gap
        inside = ~outward.any(axis=-1)
        if inside.any():  # a centre inside: minus the depth under the nearest face, its axis
            depth = halves - np.abs(local)
            least = depth.argmin(axis=-1)
            inside_distance = -np.take_along_axis(depth, least[..., None], axis=-1)[..., 0]
            distance = np.where(inside, inside_distance - t3.TOE_RADIUS, distance)
            normal = np.where(inside[..., None], np.eye(3)[least], outward)
            normal_length = np.where(inside, 1.0, gap)  # a unit axis's norm
        vertical = np.einsum("sj,...wsj->...ws", rotations[:, 2, :], normal)
        riser = np.abs(vertical) < _COS_RISER_ANGLE * normal_length
        nearest_riser = np.where(riser, distance, np.inf).min(axis=(-2, -1))
        return np.stack([distance.min(axis=(-2, -1)), nearest_riser], axis=-1)

    def toe_contacts(self, touching: dict[int, int] | None = None) -> tuple[list[int], np.ndarray]:
        """The legs whose wheels touch the terrain, and per leg a row of its wheel's
        angular and linear velocity, the contact point and the contact normal at the
        wheel's last contact in MuJoCo's list, (legs, 12). ``touching``: the legs' contacts
        as :meth:`_scan_contacts` found them (scanned now when None)."""
        if touching is None:
            _, _, touching = self._scan_contacts()
        d, contact = self.data, self.data.contact
        legs, contacts = list(touching), list(touching.values())
        rows = np.empty((len(legs), 12))
        for row, leg in zip(rows, legs, strict=True):
            mujoco.mj_objectVelocity(self.model, d, _BODY, self.wheels[leg], row[:6], 0)
        if legs:
            rows[:, 6:9] = contact.pos[contacts]
            rows[:, 9:] = contact.frame[contacts, :3]
        return legs, rows

    def slip(self) -> np.ndarray:
        """Each wheel's slip speed where it touches the terrain [m/s] (NaN in the air):
        the speed of the wheel's material at the contact point."""
        out = np.full(6, np.nan)
        legs, rows = self.toe_contacts()
        out[legs] = slip_speeds(rows, self.data.xpos[self._wheels[legs]])
        return out


def slip_speeds(rows: np.ndarray, centers: np.ndarray) -> np.ndarray:
    """The slip speed for each row of :meth:`PhysicalRobot.toe_contacts` (any number of
    them at once) and its wheel's centre: the speed of the wheel's material at the contact
    point, in the contact's tangent plane."""
    angular, linear, point, normal = rows[:, 0:3], rows[:, 3:6], rows[:, 6:9], rows[:, 9:12]
    arm = point - centers
    turning = np.stack(
        [
            angular[:, 1] * arm[:, 2] - angular[:, 2] * arm[:, 1],
            angular[:, 2] * arm[:, 0] - angular[:, 0] * arm[:, 2],
            angular[:, 0] * arm[:, 1] - angular[:, 1] * arm[:, 0],
        ],
        axis=1,
    )
    velocity = linear + turning
    # vecdot takes each row's dot product as ndarray.dot does, and np.linalg.norm too.
    tangential = velocity - normal * np.vecdot(velocity, normal)[:, None]
    return np.sqrt(np.vecdot(tangential, tangential))


@dataclass
class PhysicalRun:
    """One run's record: per cycle, and what it came to."""

    scenario: str
    body_cbf: bool
    perceived: bool = False
    t: list[float] = field(default_factory=list)
    x: list[np.ndarray] = field(default_factory=list)
    """The physical state, measured from MuJoCo (:meth:`PhysicalRobot.measure`: the
    robot's joints on the upright robot)."""
    x_estimate: list[np.ndarray] = field(default_factory=list)
    """What the gait and filter were given: ``x``, or on a perceived run its estimate."""
    x_ref: list[np.ndarray] = field(default_factory=list)
    body_contact: list[bool] = field(default_factory=list)
    toe_riser_contacts: list[int] = field(default_factory=list)
    body_distance: list[float] = field(default_factory=list)
    wheel_distance: list[tuple[float, float]] = field(default_factory=list)
    clearance: list[tuple[float, float, float]] = field(default_factory=list)
    """Exact (body, wheel, wheel-to-riser) clearances of ``x`` to the true solids: of the
    upright robot. The rolled robot's own are :attr:`body_distance` and
    :attr:`wheel_distance`, from MuJoCo's poses."""
    slip: list[np.ndarray] = field(default_factory=list)
    off_model: list[dict[str, float]] = field(default_factory=list)
    min_h: list[dict[str, float]] = field(default_factory=list)
    active_rows: list[int] = field(default_factory=list)
    """Rows applied in the QP, per cycle (Fig. 9's count)."""
    computed_rows: list[int] = field(default_factory=list)
    """Rows computed: filled instances, empty capacity slots excluded (culled included)."""
    culled_rows: list[int] = field(default_factory=list)
    """Of the computed rows, those culled by their family's lower bound."""
    update_us: list[float] = field(default_factory=list)
    """The filter update's wall time per cycle [µs]: on a busy machine it includes
    waiting for the CPU (a 4 ms scheduler slice)."""
    cpu_us: list[float] = field(default_factory=list)
    """The filter update's thread CPU time per cycle [µs]: its own cost."""
    finished: bool = False
    error: str | None = None
    finish_time: float | None = None
    nominal_body_height: list[float] = field(default_factory=list)
    raise_over_standard: list[float] = field(default_factory=list)
    """Body-centre height above the true ground under it, less the standard posture's
    (the paper's "modified above the standard height") [m]; NaN off the stairs (on the
    floor before them or on the top)."""
    perception_updates: int = 0
    swinging: list[int] = field(default_factory=list)
    """The tripod the gait lifted this cycle (0: LR RR MF, 1: MR LF RF), or -1."""

    def arrays(self) -> dict[str, np.ndarray]:
        """The series as numpy arrays."""
        out = {
            "t": np.asarray(self.t),
            "x": np.asarray(self.x),
            "x_estimate": np.asarray(self.x_estimate),
            "x_ref": np.asarray(self.x_ref),
            "nominal_body_height": np.asarray(self.nominal_body_height),
            "raise_over_standard": np.asarray(self.raise_over_standard),
            "body_contact": np.asarray(self.body_contact),
            "toe_riser_contacts": np.asarray(self.toe_riser_contacts),
            "body_distance": np.asarray(self.body_distance),
            "wheel_distance": np.asarray(self.wheel_distance),
            "clearance": np.asarray(self.clearance),
            "slip": np.asarray(self.slip),
            "active_rows": np.asarray(self.active_rows),
            "computed_rows": np.asarray(self.computed_rows),
            "culled_rows": np.asarray(self.culled_rows),
            "update_us": np.asarray(self.update_us),
            "cpu_us": np.asarray(self.cpu_us),
            "swinging": np.asarray(self.swinging, dtype=int),
        }
        for key in ("lateral", "roll", "heading"):
            out[key] = np.asarray([o[key] for o in self.off_model])
        return out

    def summary(self) -> dict[str, float | bool | str | None]:
        a = self.arrays()
        x, ref = a["x"], a["x_ref"]
        toe_error = np.hypot(x[:, 12::4] - ref[:, 12::4], x[:, 13::4] - ref[:, 13::4])
        stance_slip = a["slip"][np.isfinite(a["slip"])]
        estimate_error = np.hypot(a["x_estimate"][:, 6] - x[:, 6], a["x_estimate"][:, 7] - x[:, 7])
        raise_ = x[:, 2] + x[:, 7] - a["nominal_body_height"]
        return {
            "scenario": self.scenario,
            "body_cbf": self.body_cbf,
            "perceived": self.perceived,
            "perception_updates": self.perception_updates,
            "max_estimate_error_mm": 1e3 * float(estimate_error.max()),
            "max_body_raise_mm": 1e3 * float(np.nanmax(raise_)),
            "median_raise_over_standard_on_stairs_mm": _nan_stat(np.nanmedian, a["raise_over_standard"]),
            "max_raise_over_standard_on_stairs_mm": _nan_stat(np.nanmax, a["raise_over_standard"]),
            "finished": self.finished,
            "finish_time_s": self.finish_time,
            "error": self.error,
            "cycles": len(self.t),
            "body_contact_cycles": int(a["body_contact"].sum()),
            "toe_riser_contact_cycles": int((a["toe_riser_contacts"] > 0).sum()),
            "min_body_distance_mm": 1e3 * float(a["body_distance"].min()),
            "min_wheel_distance_mm": 1e3 * float(a["wheel_distance"][:, 0].min()),
            "min_wheel_riser_distance_mm": 1e3 * float(a["wheel_distance"][:, 1].min()),
            "wheel_riser_contact_cycles": int((a["wheel_distance"][:, 1] <= 0.0).sum()),
            "body_penetration_cycles": int((a["body_distance"] < -PENETRATION_TOLERANCE).sum()),
            "wheel_penetration_cycles": int((a["wheel_distance"][:, 0] < -PENETRATION_TOLERANCE).sum()),
            "min_body_clearance_mm": 1e3 * float(a["clearance"][:, 0].min()),
            "min_toe_clearance_mm": 1e3 * float(a["clearance"][:, 1].min()),
            "min_toe_riser_clearance_mm": 1e3 * float(a["clearance"][:, 2].min()),
            "max_body_height_error_mm": 1e3 * float(np.abs(x[:, 7] - ref[:, 7]).max()),
            "max_body_x_error_mm": 1e3 * float(np.abs(x[:, 6] - ref[:, 6]).max()),
            "max_pitch_error_deg": float(np.degrees(np.abs(x[:, 8] - ref[:, 8]).max())),
            "max_toe_error_mm": 1e3 * float(toe_error.max()),
            "p99_toe_error_mm": 1e3 * float(np.percentile(toe_error, 99)),
            "max_lateral_mm": 1e3 * float(np.abs(a["lateral"]).max()),
            "max_roll_deg": float(np.degrees(np.abs(a["roll"]).max())),
            "median_filter_cpu_us": _stat(np.median, a["cpu_us"]),
            "p99_filter_cpu_us": _stat(lambda v: np.percentile(v, 99), a["cpu_us"]),
            "max_filter_cpu_us": _stat(np.max, a["cpu_us"]),
            "max_filter_wall_us": float(a["update_us"].max()),
            "filter_cycles_over_1ms_cpu": int((a["cpu_us"] > 1000.0).sum()),
            "filter_cycles_over_1ms_wall": int((a["update_us"] > 1000.0).sum()),
            "median_slip_mm_s": 1e3 * float(np.median(stance_slip)) if stance_slip.size else 0.0,
            "p99_slip_mm_s": 1e3 * float(np.percentile(stance_slip, 99)) if stance_slip.size else 0.0,
        }


def _stat(stat, values: np.ndarray) -> float | None:
    """``stat`` of the finite values, None when there are none."""
    finite = values[np.isfinite(values)]
    return float(stat(finite)) if finite.size else None


def _nan_stat(stat, values: np.ndarray) -> float | None:
    """``stat`` of the finite values in mm, None when there are none."""
    value = _stat(stat, values)
    return None if value is None else 1e3 * value


def anchored(reference: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """``reference`` moved as one rigid body in the sagittal plane (a shift and a pitch
    about its centroid, positions and velocities) to lie closest to ``measured``.

    Rigid motions change no joint: the legs cannot make them, the ground does. Left in
    the reference, the gait's push on an error the legs cannot remove (a wheel pressed a
    millimetre into the floor by its weight) would integrate into them without bound.
    One rigid rate is the wheels' to drive: the speed along the course. The reference
    keeps its own there, up to :data:`MAX_CATCH_UP` faster or slower than the robot, so
    that a robot slipping back (MuJoCo's soft contacts creep under load) is driven on
    until it catches up, and one held by an obstacle is not driven ever harder.

    The heading is the measured one (:meth:`PhysicalRobot.measure` reads it from the body):
    on a tripod of one drive axle and a passive omnidirectional wheel the robot pivots
    freely about that axle, so the gait must see and correct its heading."""
    x = np.array(reference, dtype=float)
    x[3] = measured[3]
    # The points' positions and velocities, (reference and measured, position and
    # velocity, x and z, point); the positions' centroids (their means).
    points = np.array([x, measured])[:, _POINT_STATES]
    centers = np.add.reduce(points[:, 0], axis=2, keepdims=True) / _POINTS
    (a, b), center_q = points[:, 0] - centers, centers[1]
    # Rotation about +y by d maps (x, z) to (x cos d + z sin d, -x sin d + z cos d).
    d = np.arctan2((a[1] * b[0] - a[0] * b[1]).sum(), (a * b).sum())
    turn = _pitch_turn(d)
    moved = turn @ a + center_q
    x[_POINT_POSITIONS] = moved
    x[8] += d
    # Velocities: the same rotation, then the rigid rates (vx, vz, spin about +y) that
    # bring them closest to the measured ones, over the points and the body's pitch
    # rate; a point at r moves by spin (r_z, -r_x) under the spin.
    v, w = turn @ x[_POINT_VELOCITIES], points[1, 1]
    spun = (moved - center_q)[::-1] * _Z_DOWN
    rows = _RIGID_RATES.copy()
    rows[:-1, 2] = spun.ravel()
    rhs = np.concatenate(((w - v).ravel(), [measured[11] - x[11]]))
    vx, vz, spin = np.linalg.lstsq(rows, rhs, rcond=None)[0].tolist()
    vx -= min(max(vx, -MAX_CATCH_UP), MAX_CATCH_UP)
    x[_POINT_VELOCITIES] = v + np.array([[vx], [vz]]) + spin * spun
    x[11] += spin
    return x


def _pitch_turn(angle: float) -> np.ndarray:
    """The rotation of (x, z) about +y by ``angle``."""
    c, s = float(np.cos(angle)), float(np.sin(angle))
    return np.array([[c, s], [-s, c]])


@dataclass(frozen=True)
class PoseEstimate:
    """How the robot's state estimate differs from its physical state on a perceived run
    (assumed; the paper states no estimator): a drift that grows with the distance the
    robot has travelled, as odometry's does, and white noise each cycle. The whole robot
    (body and wheels) moves rigidly with the error, which the legs cannot see."""

    drift_per_metre: tuple[float, float] = (0.02, 0.005)
    """Forward and upward drift per metre travelled: 2 % and 0.5 %."""
    noise: tuple[float, float, float] = (0.001, 0.001, float(np.radians(0.1)))
    """Standard deviations of the per-cycle noise in x, z [m] and pitch [rad]."""
    seed: int = 1
    """Seed of the noise."""
    floor_lift: float | None = None
    """Perceived levels raised by this [m] (None: the kinematic runs' 4 mm)."""

    def __post_init__(self) -> None:
        values = (*self.drift_per_metre, *self.noise)
        if not all(np.isfinite(v) for v in values) or min(self.noise) < 0.0:
            raise ValueError(f"PoseEstimate needs finite drifts and non-negative noise, got {values}")

    def error(self, travelled: float, rng: np.random.Generator) -> np.ndarray:
        """(x, z, pitch) error after ``travelled`` metres."""
        drift = np.array([*self.drift_per_metre, 0.0]) * travelled
        return drift + rng.normal(0.0, 1.0, 3) * np.asarray(self.noise)

    def estimate(self, x: np.ndarray, error: np.ndarray) -> np.ndarray:
        """``x`` with the robot moved rigidly by ``error``: a pitch about the body centre
        (positions only, as :func:`anchored` turns them), then a shift."""
        out = np.array(x, dtype=float)
        center = out[6:8, None]  # the body's (x, z)
        d = error[2]
        moved = _pitch_turn(d) @ (out[_POINT_POSITIONS] - center) + center
        out[_POINT_POSITIONS] = moved + error[:2, None]
        out[8] += d
        return out


class _MinHByFamily:
    """Per cycle, each family's least h over its applied rows (the layout is fixed, so the
    rows are grouped by family once). :meth:`keep` reads them each cycle; the least are
    taken :attr:`CHUNK` cycles at a time, in a few numpy calls rather than a few a cycle."""

    CHUNK = 1024

    def __init__(self, filt) -> None:
        self.families = list(dict.fromkeys(family for family, *_ in filt.layout))
        index = {family: i for i, family in enumerate(self.families)}
        family_of_row = np.array([index[family] for family, *_ in filt.layout], dtype=int)
        # The rows in family order, and where each family's start.
        self.by_family = np.argsort(family_of_row, kind="stable")
        self.starts = np.searchsorted(family_of_row[self.by_family], np.arange(len(self.families)))
        self.least: list[dict[str, float]] = []
        self._h: list[np.ndarray] = []
        self._applied: list[bytes] = []

    def keep(self, filt, applicable: list[bool]) -> None:
        """This cycle's rows: ``applicable`` is ``filt.applicable``, read once a cycle by
        the caller."""
        self._h.append(filt.lie[:, 0])
        self._applied.append(bytes(applicable))  # a list of bools, compactly
        if len(self._h) == self.CHUNK:
            self.flush()

    def flush(self) -> list[dict[str, float]]:
        """Every kept cycle's least h per family (the families with an applied row), in
        :attr:`least`, which it returns."""
        if self._h:
            applied = np.frombuffer(b"".join(self._applied), dtype=bool).reshape(len(self._h), -1)
            h = np.where(applied, np.array(self._h), np.inf)
            least = np.minimum.reduceat(h[:, self.by_family], self.starts, axis=1).tolist()
            self.least.extend(
                {family: value for family, value in zip(self.families, row, strict=True) if math.isfinite(value)}
                for row in least
            )
            self._h, self._applied = [], []
        return self.least


class _RecordedGeometry:
    """What the record needs of MuJoCo's poses and contacts after each step and nothing
    else reads (the wheels' distances to the solids, their slip, the body's raise over
    the ground): kept each cycle, and turned into the record's numbers for all cycles at
    once after the run. The same numbers, without dozens of small numpy calls a cycle."""

    CHUNK = 4096
    """Cycles whose wheel distances are computed at once: their arrays' memory bounded."""

    def __init__(self, robot: PhysicalRobot, cycles: int) -> None:
        self.wheel_centers = np.empty((cycles, len(robot.wheels), 3))
        self.body_centers = np.empty((cycles, 3))
        self.touching: list[list[int]] = []
        self.toe_contacts = [np.empty((0, 12))]
        self.standard_height = float(t3.world_kinematics(t3.standard_posture())[0][2])

    def keep(self, k: int, robot: PhysicalRobot, touching: dict[int, int]) -> None:
        """Cycle ``k``'s poses and toe contacts (its record's k-th entries); ``touching``
        as :meth:`PhysicalRobot.toe_contacts` takes it."""
        self.wheel_centers[k] = robot.wheel_centers()
        self.body_centers[k] = robot.data.xpos[robot.body]
        legs, rows = robot.toe_contacts(touching)
        self.touching.append(legs)
        self.toe_contacts.append(rows)

    def fill(self, record: PhysicalRun, robot: PhysicalRobot) -> None:
        """``record``'s wheel distances, slip and raise over the standard height."""
        cycles = len(self.touching)
        for start in range(0, cycles, self.CHUNK):
            centers = self.wheel_centers[start : min(start + self.CHUNK, cycles)]
            record.wheel_distance.extend(map(tuple, robot.wheel_distances(centers).tolist()))
        slip = np.full((cycles, len(robot.wheels)), np.nan)
        cycle = np.repeat(np.arange(cycles), [len(legs) for legs in self.touching])
        leg = [leg for legs in self.touching for leg in legs]
        slip[cycle, leg] = slip_speeds(np.concatenate(self.toe_contacts), self.wheel_centers[cycle, leg])
        record.slip = list(slip)
        body = self.body_centers[:cycles]
        ground = robot.grounds_under(body)
        on_stairs = (0.0 < ground) & (ground < float(robot.solid_tops.max()) - 1e-6)
        raise_ = np.where(on_stairs, body[:, 2] - ground - self.standard_height, np.nan)
        record.raise_over_standard = raise_.tolist()


def run(
    scenario: str = "stairs",
    body_cbf: bool = True,
    max_time: float | None = None,
    params: RobotParams | None = None,
    settle: float = 0.3,
    on_cycle=None,
    perception: PoseEstimate | None = None,
    clear_the_roll: bool = True,
    origin: str = "rolling",
) -> PhysicalRun:
    """The closed loop on the physical robot until the course is finished or
    ``max_time`` [s] (the Rust simulation's limit when None). The robot first stands
    ``settle`` seconds at its initial state so the legs take its weight. ``on_cycle(k,
    robot)`` is called after every step (a renderer hooks in there).

    With ``perception`` (a :class:`PoseEstimate`) the run is the paper's hardware
    experiment: the gait and the filter see only what the LiDAR on the body perceives
    (:meth:`cbfgen.tachyon3.Course.perceive`: 10 Hz scans, 1 Hz updates), and they, the
    scans' registration and the reference act on the state *estimate*, the physical state
    with the estimate's drift and noise. Safety is still measured from MuJoCo's own poses
    against the true terrain.

    With ``clear_the_roll`` the body rows keep the model's body clear of every edge by
    the farthest its measured roll (an IMU's) moves any point of the box
    (:meth:`cbfgen.tachyon3.Course.set_body_roll`): the sagittal model holds no roll.

    ``origin`` is how the ground-moving origin moves (``Course``'s ``origin``):
    ``"rolling"`` or the paper's ``"jump_at_exchange"``."""
    check_physical_scenario(scenario)
    course = (
        t3.Course(scenario, perception=True, floor_lift=perception.floor_lift, origin=origin)
        if perception is not None
        else t3.Course(scenario, origin=origin)
    )
    rng = np.random.default_rng(perception.seed) if perception is not None else None
    settings = {} if body_cbf else {"activation": {BODY_FAMILY: float("-inf")}}
    filt = t3.ecbf_filter(measure_cpu_time=True, **settings)
    min_h_by_family = _MinHByFamily(filt)
    robot = PhysicalRobot(course, params)
    x_ref = course.initial_state()
    robot.pose(x_ref)
    for _ in range(int(round(settle / TIMESTEP))):
        robot.step()
    limit = max_time if max_time is not None else course.time_allowed
    record = PhysicalRun(scenario=scenario, body_cbf=body_cbf, perceived=perception is not None)
    start = np.array(x_ref[0:3])
    cycles = int(round(limit / t3.DT))
    geometry = _RecordedGeometry(robot, cycles)

    for k in range(cycles):
        t = k * t3.DT
        # The origin moves onto the drive axle a turning swing turns about, and back.
        x_ref, _jump = course.exchange_origin(t, x_ref)
        truth, off_model = robot.measure(x_ref)
        x = truth
        if abs(off_model["roll"]) > TIP_OVER_ROLL:
            record.error = f"t = {t:.3f} s: tipped over (roll {np.degrees(off_model['roll']):.0f}°)"
            break
        try:
            if clear_the_roll:
                course.set_body_roll(off_model["roll"])
            if perception is not None:
                offset = truth[0:3] - start
                travelled = math.sqrt(offset.dot(offset))  # np.linalg.norm's sum
                x = perception.estimate(truth, perception.error(travelled, rng))
                course.perceive(t, x, truth)
            u_ref = course.plan(t, x)
            out = filt.update(x, u_ref, course.environment, t)
        except CbfError as error:
            # The physical robot left the model's domain (it fell, say): the run ends
            # there, and says why.
            record.error = f"t = {t:.3f} s: {error}"
            break
        x_ref = anchored(x_ref, x)
        x_ref = x_ref + t3.DT * t3.SYSTEM.xdot(x_ref, out.u)
        robot.command(x_ref)
        robot.step()
        body_contact, toe_riser, touching = robot._scan_contacts()
        record.t.append(t)
        record.x.append(truth)
        record.x_estimate.append(x)
        record.x_ref.append(x_ref.copy())
        record.body_contact.append(body_contact)
        record.toe_riser_contacts.append(toe_riser)
        record.body_distance.append(robot.body_distance())
        record.clearance.append(course.clearance(truth))
        record.off_model.append(off_model)
        applicable = filt.applicable
        min_h_by_family.keep(filt, applicable)
        record.active_rows.append(out.active_rows)
        record.computed_rows.append(sum(applicable))
        record.culled_rows.append(sum(filt.culled))
        record.update_us.append(out.eval_time_us + out.solve_time_us)
        record.cpu_us.append(np.nan if out.cpu_time_us is None else out.cpu_time_us)
        record.nominal_body_height.append(course.nominal_body_height or np.nan)
        record.swinging.append(-1 if course.swinging is None else course.swinging)
        geometry.keep(k, robot, touching)
        if on_cycle is not None:
            on_cycle(k, robot)
        if course.finished(truth):
            record.finished, record.finish_time = True, t
            break
    record.perception_updates = course.perception_updates
    record.min_h = min_h_by_family.flush()
    geometry.fill(record, robot)
    return record
