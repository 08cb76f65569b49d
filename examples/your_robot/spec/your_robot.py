"""A unicycle robot kept below a speed limit, inside a corridor and out of round obstacles.

This file is all a new robot needs: `build.rs` hands it to cbfgen-build, which generates
the Rust module into OUT_DIR whenever this file changes.
"""

import symengine as se

from symbolic import primitives as prim
from symbolic.spec import Positive, System


def build() -> System:
    s = System("your_robot", doc="A unicycle: position, heading and forward speed, driven by "
                                 "forward acceleration and turn rate.")
    px, py, heading, speed = s.states(["px", "py", "heading", "speed"],
                                      docs=["x position [m]", "y position [m]", "heading [rad]",
                                            "forward speed [m/s]"])
    s.inputs(["accel", "turn_rate"], limits=[(-2.0, 2.0), (-1.5, 1.5)],
             docs=["forward acceleration [m/s^2]", "turn rate [rad/s]"])
    s.dynamics(f=[speed * se.cos(heading), speed * se.sin(heading), 0, 0],
               g=[[0, 0], [0, 0], [0, 1], [1, 0]])

    # Relative degree 1: the acceleration acts on the speed directly.
    s.family("speed_limit", lambda p: p.max_speed - speed, params={"max_speed": ((), "[m/s]")},
             count=1, poles=[2.0], doc="Forward speed below max_speed [m/s].")
    # Relative degree 2 (found by the generator): both inputs act on the second derivative.
    s.family("obstacle", lambda p: (px - p.center[0])**2 + (py - p.center[1])**2 - p.radius**2,
             # h uses radius^2: a negative radius would pass for a positive one, so declare it > 0.
             params={"center": ((2,), "obstacle centre [m]"),
                     "radius": ((), "robot + obstacle radius [m]", Positive())},
             capacity=True, poles=[3.0, 3.0], activation=4.0,
             doc="Centre outside the obstacle's disc, inflated by the robot's radius [m^2].")
    # prim.half_space asks for a unit normal: the generated checks refuse any other.
    s.family("corridor", lambda p: prim.half_space([px, py], p.normal, p.offset),
             params={"normal": ((2,), "unit normal into the free side"), "offset": ((), "[m]")},
             count=2, poles=[3.0, 3.0], doc="Centre on the free side of a corridor wall [m].")
    return s
