"""A test spec whose parameters take their domains from the primitives they are used in,
as a user's spec would: a planar robot (double-integrator dynamics) in a room with a
fixed pillar (smooth SAT against its box), posts (sphere-box), blobs (superellipsoid,
inflated) and optional fences (half-spaces), under a speed limit whose bound declares
an interval. Only the speed limit declares a domain; every other one comes from
prim.Box, prim.sphere_box, prim.superellipsoid and prim.half_space."""

from __future__ import annotations

import symengine as se

from symbolic import primitives as prim
from symbolic.spec import Interval, System


def build() -> System:
    s = System("boxed_robot", doc="A planar robot among a pillar, posts, blobs and fences whose parameters "
                                   "carry the primitives' domains.")
    px, py, vx, vy = s.states(["px", "py", "vx", "vy"],
                              docs=["x position [m]", "y position [m]", "x velocity [m/s]", "y velocity [m/s]"])
    s.inputs(["ax", "ay"], limits=[(-4.0, 4.0), (-4.0, 4.0)],
             docs=["x acceleration [m/s^2]", "y acceleration [m/s^2]"])
    s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
    zero = se.Integer(0)
    robot = prim.Box([px, py, zero], prim.identity(), [se.RealDouble(0.2), se.RealDouble(0.1), se.RealDouble(0.1)])

    # A fixed instance: its centre and extents start unset (refused until set), its
    # rotation at the spec's default.
    s.family("pillar", lambda p: prim.ssat(p, prim.Box(p.center, p.rotation, p.half_extents), robot, alpha=50.0,
                                           alpha_rot=50.0),
             params={"center": ((3,), "pillar centre [m]"), "rotation": ((3, 3), "pillar rotation"),
                     "half_extents": ((3,), "pillar half extents [m]")},
             defaults={"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},
             count=1, poles=[5.0, 5.0], doc="The robot's box out of the pillar's, by the smooth SAT [m].")
    # Half extents as three scalar parameters, the rotation built from an angle.
    s.family("post", lambda p: prim.sphere_box(p, [px, py, zero], p.radius,
                                               prim.Box(p.center, prim.rot_z(p.yaw), [p.hx, p.hy, p.hz])),
             params={"center": (3,), "yaw": (), "hx": (), "hy": (), "hz": (), "radius": ((), "robot radius [m]")},
             capacity=4, poles=[5.0, 5.0], doc="A sphere about the robot's centre out of a post's box [m].")
    s.family("blob", lambda p: prim.superellipsoid(p, [px, py, zero], prim.Box(p.center, p.rotation, p.half),
                                                   inflate=p.margin),
             params={"center": (3,), "rotation": (3, 3), "half": (3,), "margin": ()},
             capacity=4, poles=[5.0, 5.0], doc="The robot's centre outside a blob grown by a margin.")
    s.family("fence", lambda p: prim.half_space([px, py], p.normal, p.offset),
             params={"normal": ((2,), "inward normal"), "offset": ((), "[m]")},
             count=2, optional=True, poles=[5.0, 5.0], doc="The robot's centre on the inner side of a fence [m].")
    s.family("speed_limit", lambda p: p.vmax**2 - vx**2 - vy**2,
             params={"vmax": ((), "speed limit [m/s]", Interval(0.1, 5.0))}, defaults={"vmax": 2.0}, count=1,
             poles=[5.0],
             doc="Speed below vmax [m^2/s^2].")
    return s
