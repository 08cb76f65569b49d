"""Tachyon 3 as a MuJoCo model (MJCF), built from the constants the generated code was
built from (``systems/tachyon3/spec/tachyon3.toml`` via ``cbfgen.tachyon3``), on a course's true
terrain.

Each leg is a hip hinge at its mount (axis chosen so the joint angle *is* the model's hip
angle, positive outward), a prismatic knee along the leg (its position *is* the knee
length) and a wheel, a sphere of the toe radius. As on the robot (the paper's Fig. 2),
the four outer wheels are driven, on a hinge about the lateral axis, and the two middle
ones are passive and omnidirectional, on a ball joint, so that they roll sideways when
the robot turns about a drive axle. Hips and knees are PD servos on a position and a
velocity target; so are the driven wheels, whose angle target integrates the spin the
toe's ground speed needs. Robot geoms collide with the terrain only.

What the paper does not state is assumed and listed in :data:`ASSUMED`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .. import tachyon3 as t3

TIMESTEP = 0.001
"""MuJoCo's time step [s]: the filter's 1 kHz cycle."""


@dataclass(frozen=True)
class RobotParams:
    """Masses and servo gains (assumed: the paper states neither)."""

    body_mass: float = 40.0
    """Body box [kg]."""
    thigh_mass: float = 1.5
    """Hip-side link of each leg [kg]."""
    shin_mass: float = 1.0
    """Knee-side link of each leg [kg]."""
    wheel_mass: float = 1.5
    """Each wheel [kg]."""
    hip_kp: float = 4000.0
    """Hip stiffness [N m/rad]."""
    hip_kv: float = 150.0
    """Hip damping on the velocity error [N m s/rad]."""
    knee_kp: float = 60000.0
    """Knee stiffness [N/m]: about 3.5 mm of sag under a third of the robot's weight."""
    knee_kv: float = 2500.0
    """Knee damping on the velocity error [N s/m]: about critical for the body on three legs."""
    wheel_kp: float = 400.0
    """Wheel stiffness about its angle target [N m/rad]: a wheel holds the robot on a
    slope by its angle, not by running slow."""
    wheel_kv: float = 30.0
    """Wheel damping on the spin error [N m s/rad]."""
    friction: float = 1.0
    """Sliding friction, wheels and terrain (rubber on wood or concrete)."""
    contact_time_constant: float = 0.005
    """MuJoCo's contact stiffness as its ``solref`` time constant [s], five time steps: at
    MuJoCo's default (0.02 s) a wheel carrying its share of the robot sank up to 2.6 mm
    into its tread, more than a wheel on wood does and than the 1 mm the climb is held to."""
    joint_armature: float = 0.01
    """Rotor inertia added to each joint [kg m^2 or kg]."""

    @property
    def total_mass(self) -> float:
        return self.body_mass + 6 * (self.thigh_mass + self.shin_mass + self.wheel_mass)


ASSUMED = asdict(RobotParams())
"""The assumed values, for reports."""


def _vec(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def _quat(rotation: np.ndarray) -> str:
    """MuJoCo's (w, x, y, z) of a rotation matrix."""
    r = np.asarray(rotation, dtype=float)
    w = np.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2.0
    if w > 1e-6:
        q = [w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w)]
    else:  # a half turn: the axis from the largest diagonal entry
        k = int(np.argmax(np.diag(r)))
        i, j = (k + 1) % 3, (k + 2) % 3
        s = np.sqrt(max(0.0, 1.0 + r[k, k] - r[i, i] - r[j, j])) * 2.0
        q = [0.0, 0.0, 0.0, 0.0]
        q[0] = (r[j, i] - r[i, j]) / s
        q[1 + k] = s / 4.0
        q[1 + i] = (r[i, k] + r[k, i]) / s
        q[1 + j] = (r[j, k] + r[k, j]) / s
    return _vec(q)


def robot_mjcf(course: t3.Course, params: RobotParams | None = None) -> str:
    """The MJCF of Tachyon 3 on ``course``'s true terrain (its solid boxes)."""
    p = RobotParams() if params is None else params
    half = t3.BODY_HALF_EXTENTS
    r = t3.TOE_RADIUS
    knee_lo, knee_hi = t3.KNEE_RANGE
    terrain = []
    for k, (center, rotation, half_extents) in enumerate(course.terrain_boxes()):
        terrain.append(
            f'    <geom name="terrain{k}" type="box" pos="{_vec(center)}" quat="{_quat(rotation)}" '
            f'size="{_vec(half_extents)}" contype="1" conaffinity="1" material="terrain"/>'
        )
    legs = []
    for leg, name in enumerate(t3.LEG_NAMES):
        wheel_joint = (
            f'<joint name="{name}_wheel" type="hinge" axis="0 1 0"/>'
            if leg in t3.DRIVE_LEGS
            else f'<joint name="{name}_wheel" type="ball"/>'
        )
        hip = t3.HIP_POSITIONS[leg]
        outward = t3.HIP_OUTWARD[leg]
        lo, hi = t3.HIP_RANGES[leg]
        legs.append(f"""      <body name="{name}_thigh" pos="{_vec(hip)}">
        <joint name="{name}_hip" type="hinge" axis="0 {-outward:g} 0" range="{lo:.9g} {hi:.9g}"/>
        <geom name="{name}_thigh" type="capsule" fromto="0 0 0 0 0 {-knee_lo:.9g}" size="0.035"
              mass="{p.thigh_mass:g}" contype="0" conaffinity="0" material="leg"/>
        <body name="{name}_shin">
          <joint name="{name}_knee" type="slide" axis="0 0 -1" range="{knee_lo:.9g} {knee_hi:.9g}"/>
          <geom name="{name}_shin" type="capsule" fromto="0 0 0 0 0 {knee_lo + 0.12:.9g}" size="0.025"
                mass="{p.shin_mass:g}" contype="0" conaffinity="0" material="leg"/>
          <body name="{name}_wheel">
            {wheel_joint}
            <geom name="{name}_toe" type="sphere" size="{r:.9g}" mass="{p.wheel_mass:g}" material="wheel"/>
          </body>
        </body>
      </body>""")
    actuators = []
    for name in t3.LEG_NAMES:
        actuators += [
            f'    <position name="{name}_hip_pos" joint="{name}_hip" kp="{p.hip_kp:g}"/>',
            f'    <velocity name="{name}_hip_vel" joint="{name}_hip" kv="{p.hip_kv:g}"/>',
            f'    <position name="{name}_knee_pos" joint="{name}_knee" kp="{p.knee_kp:g}"/>',
            f'    <velocity name="{name}_knee_vel" joint="{name}_knee" kv="{p.knee_kv:g}"/>',
        ]
    for leg in t3.DRIVE_LEGS:
        name = t3.LEG_NAMES[leg]
        actuators += [
            f'    <position name="{name}_wheel_pos" joint="{name}_wheel" kp="{p.wheel_kp:g}"/>',
            f'    <velocity name="{name}_wheel_vel" joint="{name}_wheel" kv="{p.wheel_kv:g}"/>',
        ]
    nl = "\n"
    return f"""<mujoco model="tachyon3">
  <compiler angle="radian" autolimits="true" inertiafromgeom="true"/>
  <option timestep="{TIMESTEP}" integrator="implicitfast"/>
  <visual>
    <global offwidth="1280" offheight="720"/>
    <quality shadowsize="2048"/>
  </visual>
  <default>
    <geom contype="2" conaffinity="1" friction="{p.friction:g} 0.005 0.0001" condim="3"
          solref="{p.contact_time_constant:g} 1"/>
    <joint armature="{p.joint_armature:g}" damping="0"/>
  </default>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.62 0.76 0.90" rgb2="0.95 0.96 0.98"
             width="256" height="256"/>
    <texture name="grid" type="2d" builtin="checker" rgb1="0.82 0.80 0.76" rgb2="0.72 0.70 0.66"
             width="256" height="256"/>
    <material name="terrain" texture="grid" texrepeat="8 8" rgba="0.85 0.83 0.8 1"/>
    <material name="body" rgba="0.20 0.42 0.72 1"/>
    <material name="leg" rgba="0.35 0.35 0.38 1"/>
    <material name="wheel" rgba="0.12 0.12 0.12 1"/>
  </asset>
  <worldbody>
    <light pos="0 -3 5" dir="0.2 0.6 -1" directional="true" diffuse="0.8 0.8 0.8"/>
{nl.join(terrain)}
    <body name="body">
      <freejoint name="root"/>
      <geom name="body" type="box" size="{_vec(half)}" mass="{p.body_mass:g}" material="body"/>
{nl.join(legs)}
    </body>
  </worldbody>
  <actuator>
{nl.join(actuators)}
  </actuator>
</mujoco>
"""
