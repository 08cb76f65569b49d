"""ANYmal C in MuJoCo under seed 004's whole-body controller (its section IV-C).

The plant is MuJoCo's model of the robot's own URDF (:func:`.urdf_model.mjcf_from_urdf`:
its inertials and collision primitives; soft contacts with friction 0.8 on a flat
ground), stepped at 2 kHz. Every 2.5 ms (400 Hz, the seed's rate) the controller
(:class:`cbfgen.anymal.WholeBodyController`) reads MuJoCo's state — the trunk's position
and orientation, its twist (MuJoCo's free joint gives the world linear velocity, turned
into the trunk's frame here), the joints — and its torques drive the motors until the next
cycle. The reference is the trot of :func:`cbfgen.anymal.trot`: standing, a trot in place,
or a trot at a commanded velocity. :func:`walk_stones` walks seed 004's stepping stones
with both layers instead (:class:`cbfgen.anymal.StoneWalk`: the kino-dynamic MPC and
the controller).

Measured against MuJoCo's world, not the controller's model: the trunk's height, every
contact of a geom other than the four foot spheres with the ground (a body contact), and
each swing foot's centre against its foothold square.

    from cbfgen.physics.anymal import run

    record = run("trot", seconds=10.0)
    print(record.summary())
"""

from __future__ import annotations

import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import anymal
from .urdf_model import mjcf_from_urdf

try:
    import mujoco
except ImportError as missing:  # pragma: no cover - the message is the point
    raise ImportError("cbfgen.physics needs MuJoCo's Python bindings: pip install -r python/requirements.txt "
                      "(or scripts/cbf setup)") from missing

DESCRIPTION = "anymal_c_simple_description/urdf/anymal.urdf"
TIMESTEP = 0.0005
"""MuJoCo's step [s] (2 kHz)."""
STEPS_PER_CYCLE = 5
"""MuJoCo steps per controller cycle: 400 Hz."""
SWING = 0.3
"""Each pair's swing time [s] (a stance lasts as long)."""
LIFT = 0.08
"""How high a swing foot rises [m]."""
SCENARIOS = ("stand", "trot", "footholds")


def description_path(relative: str = DESCRIPTION) -> Path:
    """A file of example-robot-data's robots (installed from PyPI, read offline). The
    generator's ``symbolic.urdf.description`` finds it the same way; the installed wheel
    does not carry ``symbolic``, so the runtime looks for itself."""
    for entry in sys.path:
        candidate = Path(entry) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / relative
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"example-robot-data is not installed (looked for {relative}): "
                            "pip install -r symbolic/requirements-urdf.txt (scripts/cbf setup does)")


class Robot:
    """MuJoCo's ANYmal C and the conversion of its state to the controller's; ``ground``
    and ``world`` as :func:`.urdf_model.mjcf_from_urdf` takes them (terrain)."""

    def __init__(self, ground: float | None = 0.0, world: list[str] | None = None) -> None:
        path = description_path()
        text = mjcf_from_urdf(path, timestep=TIMESTEP, name="anymal_c", ground=ground, world=world)
        self.model = mujoco.MjModel.from_xml_string(text)
        self.data = mujoco.MjData(self.model)
        joint = mujoco.mjtObj.mjOBJ_JOINT
        ids = [mujoco.mj_name2id(self.model, joint, name) for name in anymal.JOINT_NAMES]
        self.qadr = np.array([self.model.jnt_qposadr[i] for i in ids])
        self.vadr = np.array([self.model.jnt_dofadr[i] for i in ids])
        actuator = mujoco.mjtObj.mjOBJ_ACTUATOR
        self.actuators = np.array([mujoco.mj_name2id(self.model, actuator, name) for name in anymal.JOINT_NAMES])
        # Each foot's sphere: the one sphere among its FOOT link's collisions.
        root = ET.parse(path).getroot()
        self.feet = []
        for leg in anymal.LEGS:
            (link,) = [e for e in root.findall("link") if e.get("name") == f"{leg}_FOOT"]
            kinds = [c.find("geometry")[0].tag for c in link.findall("collision")]
            name = f"{leg}_FOOT_{kinds.index('sphere')}"
            self.feet.append(mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name))
        # The terrain: every geom of the world body (the ground, stones).
        self.terrain = {g for g in range(self.model.ngeom) if self.model.geom_bodyid[g] == 0}

    def place(self, x: np.ndarray) -> None:
        """Set MuJoCo's state from a controller state ``x``."""
        d = self.data
        d.qpos[:3] = x[:3]
        quaternion = np.zeros(4)
        mujoco.mju_mat2Quat(quaternion, x[3:12])
        d.qpos[3:7] = quaternion
        d.qpos[self.qadr] = x[12:24]
        rotation = x[3:12].reshape(3, 3)
        d.qvel[:3] = rotation @ x[24:27]
        d.qvel[3:6] = x[27:30]
        d.qvel[self.vadr] = x[30:42]
        mujoco.mj_forward(self.model, d)

    def measure(self) -> np.ndarray:
        """The controller's state (the ``anymal_wbc`` layout) from MuJoCo's."""
        d = self.data
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, d.qpos[3:7])
        x = np.empty(42)
        x[:3] = d.qpos[:3]
        x[3:12] = rotation
        x[12:24] = d.qpos[self.qadr]
        x[24:27] = rotation.reshape(3, 3).T @ d.qvel[:3]  # world -> trunk frame
        x[27:30] = d.qvel[3:6]  # MuJoCo's free joint: angular velocity in the body's frame
        x[30:42] = d.qvel[self.vadr]
        return x

    def foot_centres(self) -> np.ndarray:
        return self.data.geom_xpos[self.feet].copy()

    def foot_velocities(self) -> np.ndarray:
        """Each foot sphere's centre's velocity (world), shape (4, 3)."""
        out, twist = np.empty((4, 3)), np.zeros(6)
        for k, geom in enumerate(self.feet):
            mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_GEOM, geom, twist, 0)
            out[k] = twist[3:]
        return out

    def body_contact(self) -> bool:
        """Whether any geom but the foot spheres touches the terrain."""
        d = self.data
        for c in d.contact[:d.ncon]:
            other = c.geom2 if c.geom1 in self.terrain else c.geom1 if c.geom2 in self.terrain else None
            if other is not None and other not in self.feet and other not in self.terrain:
                return True
        return False


@dataclass
class AnymalRun:
    """One run, sampled at every controller cycle."""

    scenario: str
    cbf: bool
    t: list[float] = field(default_factory=list)
    trunk: list[np.ndarray] = field(default_factory=list)
    trunk_reference: list[np.ndarray] = field(default_factory=list)
    feet: list[np.ndarray] = field(default_factory=list)
    stance: list[list[bool]] = field(default_factory=list)
    relaxed: list[np.ndarray] = field(default_factory=list)
    solved: list[bool] = field(default_factory=list)
    priority_0_residual: list[float] = field(default_factory=list)
    """Priority 0's task residual each cycle (equations of motion per kg, stance feet's
    accelerations, swing feet's forces in the QP's units: m/s², its rows are hard)."""
    body_contact: list[bool] = field(default_factory=list)
    outside: list[np.ndarray] = field(default_factory=list)
    """Per foot, how far its centre is beyond its square (positive: outside) while it swings."""
    squares: np.ndarray | None = None
    qpos: list[np.ndarray] = field(default_factory=list)

    def summary(self) -> dict[str, object]:
        trunk, reference = np.array(self.trunk), np.array(self.trunk_reference)
        outside = np.array(self.outside) if self.outside else np.zeros((1, 4))
        return {
            "scenario": self.scenario,
            "cbf": self.cbf,
            "seconds": round(self.t[-1], 4) if self.t else 0.0,
            "every_cycle_solved": bool(all(self.solved)),
            "largest_priority_0_residual": float(max(self.priority_0_residual, default=0.0)),
            "body_contacts": int(np.sum(self.body_contact)),
            "trunk_height_range_m": [float(trunk[:, 2].min()), float(trunk[:, 2].max())],
            "largest_trunk_error_m": float(np.max(np.abs(trunk - reference))),
            "travelled_m": float(trunk[-1, 0] - trunk[0, 0]),
            "farthest_outside_square_m": float(np.max(outside)) if self.squares is not None else None,
            "largest_cbf_slack": float(np.max(self.relaxed)) if self.relaxed else 0.0,
        }


def run(scenario: str = "trot", *, cbf: bool = True, seconds: float = 10.0, velocity: float = 0.3,
        reach: float = 0.1, square: float = 0.03, keep_every: int = 0) -> AnymalRun:
    """``scenario`` "stand", "trot" (at ``velocity`` m/s forward) or "footholds" (a trot in
    place, LF asked ``reach`` m forward at mid-swing, each foot's region a square of
    half-width ``square`` around where it stands, the CBF on or off); ``keep_every`` > 0
    keeps MuJoCo's qpos every that many cycles (for an animation)."""
    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}; one of {', '.join(SCENARIOS)}")
    robot = Robot()
    x = anymal.standing()
    robot.place(x)
    home = robot.foot_centres()
    trunk = x[:3].copy()
    controller = anymal.WholeBodyController()
    record = AnymalRun(scenario, cbf)
    walking = scenario != "stand"
    speed = np.array([velocity, 0.0]) if scenario == "trot" else np.zeros(2)
    asked = reach if scenario == "footholds" else 0.0
    if scenario == "footholds":
        record.squares = np.array([[c[0] - square, c[0] + square, c[1] - square, c[1] + square] for c in home])
        if cbf:
            for foot, (x0, x1, y0, y1) in enumerate(record.squares):
                normals = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
                controller.set_footholds(foot, normals, np.array([x1, -x0, y1, -y0]))
    cycle = TIMESTEP * STEPS_PER_CYCLE
    for k in range(int(round(seconds / cycle))):
        t = k * cycle
        x = robot.measure()
        if walking:
            stance, trunk_position, trunk_velocity, p, v, a = anymal.trot(t, SWING, LIFT, asked, home, trunk, speed)
        else:
            stance, trunk_position, trunk_velocity = [True] * 4, trunk, np.zeros(3)
            p = v = a = np.zeros((4, 3))
        out = controller.update(x, stance, trunk_position, np.eye(3), trunk_velocity, np.zeros(3), p, v, a, dt=cycle)
        robot.data.ctrl[robot.actuators] = out["torques"]
        for _ in range(STEPS_PER_CYCLE):
            mujoco.mj_step(robot.model, robot.data)
        feet = robot.foot_centres()
        record.t.append(t + cycle)
        record.trunk.append(robot.data.qpos[:3].copy())
        record.trunk_reference.append(np.asarray(trunk_position, dtype=float).copy())
        record.feet.append(feet)
        record.stance.append(list(stance))
        record.relaxed.append(np.asarray(out["relaxed"]))
        record.solved.append(bool(out["solved"]))
        record.priority_0_residual.append(float(out["residuals"][0]))
        record.body_contact.append(robot.body_contact())
        if record.squares is not None:
            s = record.squares
            beyond = np.maximum.reduce([s[:, 0] - feet[:, 0], feet[:, 0] - s[:, 1], s[:, 2] - feet[:, 1],
                                        feet[:, 1] - s[:, 3]])
            record.outside.append(np.where(stance, -np.inf, beyond))
        if keep_every and k % keep_every == 0:
            record.qpos.append(robot.data.qpos.copy())
    return record


STONE_DEPTH = 0.5
"""How far a stone reaches below its top [m]; the ground lies this far below z = 0, where
a foot that misses falls."""


def stone_geoms(stones: np.ndarray) -> list[str]:
    """MJCF box geoms for a :class:`cbfgen.anymal.SteppingStones` field's ``stones``
    (each row: top centre x, y, z, half side)."""
    return [
        f'    <geom name="stone_{k}" type="box" pos="{x!r} {y!r} {z - STONE_DEPTH / 2!r}" '
        f'size="{h!r} {h!r} {STONE_DEPTH / 2!r}" rgba="0.55 0.5 0.45 1" contype="2" conaffinity="1"/>'
        for k, (x, y, z, h) in enumerate(np.asarray(stones, dtype=float).tolist())
    ]


@dataclass
class StoneRun:
    """One stepping-stone walk in MuJoCo: Table II's record, and MuJoCo's model and poses
    for a video."""

    record: dict[str, object]
    model: object
    qpos: list[np.ndarray] = field(default_factory=list)
    body_contact: list[bool] = field(default_factory=list)


def walk_stones(stones: anymal.SteppingStones, controller: str = "CBF in QP & MPC", *,
                keep_every: int = 0, threaded: bool = False, gamma: float | None = None,
                barrier: str | None = None, mpc_stage: float | None = None,
                whole_body_barrier: str | None = None) -> StoneRun:
    """Seed 004's stepping-stone walk (section V) in MuJoCo: ``stones`` as boxes over a
    ground far below, the robot on its starting stones, ``controller`` (one of
    ``cbfgen.anymal.CONTROLLERS``) at 400 Hz until the walk's end. A fall is a body
    contact with the terrain, or the trunk sinking below half its standing height above
    the stones; the run stops there. The record is
    :meth:`cbfgen.anymal.StoneWalk.record`'s (measured on MuJoCo's foot spheres against
    the stones) with ``controller``, ``body_contact`` and ``travelled_m`` added; MuJoCo's
    qpos is kept every ``keep_every`` cycles when positive (for a video). ``threaded`` runs
    the MPC in its own thread and the loop no faster than real time, so that plans are as
    late as the machine makes them; the record's ``behind_real_time_s`` says how far the
    loop itself fell behind (where it did, the plans were early by as much). ``gamma``
    and ``barrier``: eq. 25's rate and the set its CBF (the MPC's) keeps a swing foot in,
    ``whole_body_barrier`` the set of eq. 26's (the whole-body QP's), ``mpc_stage`` the
    MPC's stage length [s] (:class:`cbfgen.anymal.StoneWalk`; ``None``: its defaults)."""
    robot = Robot(ground=-STONE_DEPTH, world=stone_geoms(stones.stones))
    x = anymal.standing()
    robot.place(x)
    standing_height = x[2]
    walk = anymal.StoneWalk(stones, controller, gamma=gamma, threaded=threaded, barrier=barrier, mpc_stage=mpc_stage,
                            whole_body_barrier=whole_body_barrier)
    run = StoneRun({}, robot.model)
    cycle = TIMESTEP * STEPS_PER_CYCLE
    body_contact = False
    start, behind = time.perf_counter(), 0.0
    for k in range(int(np.ceil(stones.end / cycle))):
        t = k * cycle
        if threaded:
            ahead = t - (time.perf_counter() - start)
            if ahead > 0.0:
                time.sleep(ahead)
            behind = max(behind, -ahead)
        x = robot.measure()
        feet = robot.foot_centres()
        out = walk.update(t, x, feet, robot.foot_velocities())
        robot.data.ctrl[robot.actuators] = out["torques"]
        for _ in range(STEPS_PER_CYCLE):
            mujoco.mj_step(robot.model, robot.data)
        body_contact = robot.body_contact()
        if keep_every and k % keep_every == 0:
            run.qpos.append(robot.data.qpos.copy())
            run.body_contact.append(body_contact)
        ground = np.mean([stones.nearest_top(f[0], f[1]) for f in feet])
        if body_contact or robot.data.qpos[2] - ground < 0.5 * standing_height or not np.all(np.isfinite(x)):
            walk.fell(t)
            break
    run.record = walk.record()
    run.record.update(controller=controller, body_contact=body_contact, threaded=threaded,
                      behind_real_time_s=behind, travelled_m=float(robot.data.qpos[0] - anymal.standing()[0]))
    return run
