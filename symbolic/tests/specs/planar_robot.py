"""A test spec: a planar robot (a small box) with double-integrator dynamics, a speed
limit (relative degree 1) and box walls by the smooth SAT (relative degree 2)."""

from __future__ import annotations

import symengine as se

from symbolic import primitives as prim
from symbolic.spec import System

ROBOT_HALF_EXTENTS = (0.3, 0.2, 0.25)  # [m]


def build() -> System:
    s = System("planar_robot", doc="A planar point robot, double-integrator dynamics, kept below a "
                                   "speed limit and out of box-shaped walls.")
    px, py, vx, vy = s.states(["px", "py", "vx", "vy"],
                              docs=["x position [m]", "y position [m]", "x velocity [m/s]", "y velocity [m/s]"])
    s.inputs(["ax", "ay"], limits=[(-4.0, 4.0), (-4.0, 4.0)],
             docs=["x acceleration [m/s^2]", "y acceleration [m/s^2]"])
    s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
    s.family("speed_limit", lambda p: p.vmax**2 - vx**2 - vy**2,
             params={"vmax": ((), "speed limit [m/s]")}, count=1, poles=[5.0], priority=1,
             activation=float("inf"), doc="Speed below vmax: h = vmax^2 - |v|^2 [m^2/s^2].")
    robot = prim.Box([px, py, se.Integer(0)], prim.identity(), [se.RealDouble(v) for v in ROBOT_HALF_EXTENTS])

    def wall(p):
        return prim.ssat(p, prim.Box(p.center, p.rotation, p.half_extents), robot, alpha=50.0, alpha_rot=50.0)

    s.family("wall", wall,
             params={"center": ((3,), "wall centre, world frame [m]"),
                     "rotation": ((3, 3), "wall rotation, columns = its axes in the world frame"),
                     "half_extents": ((3,), "wall half extents [m]")},
             capacity=True, poles=[10.0, 10.0], activation=2.0,
             doc="The robot's box out of an oriented box wall: the smooth SAT minus its certified margin [m].")
    return s
