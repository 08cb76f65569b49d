"""A test spec: a planar point robot whose filter cost is a state-dependent quadratic.

States: position (px, py) [m] and velocity (vx, vy) [m/s]; inputs the accelerations (ax, ay),
within +-2 m/s^2. Families: a wall at px = 1 (degree 2) and a disc obstacle of radius 0.2 m
at (0.5, 0.3) (degree 2). The objective couples the inputs along the velocity,
P(x) = [[1 + vx^2, 2 vx vy], [2 vx vy, 1 + vy^2]], with a pull q(x) = (0.5 px, -0.3 py):
positive definite while 3 vx^2 vy^2 < 1 + vx^2 + vy^2 (so for |vx|, |vy| <= 0.7), and not
at vx = vy = 1.5, where the filter must refuse it.
"""

from __future__ import annotations

from symbolic.spec import System

WALL_X = 1.0  # m
DISC_CENTRE = (0.5, 0.3)  # m
DISC_RADIUS = 0.2  # m


def build() -> System:
    s = System("drag_weighted_robot", doc="A planar point robot whose filter cost couples its accelerations "
                                          "along its velocity.")
    px, py, vx, vy = s.states(["px", "py", "vx", "vy"],
                              docs=["x position [m]", "y position [m]", "x velocity [m/s]", "y velocity [m/s]"])
    s.inputs(["ax", "ay"], limits=[(-2.0, 2.0), (-2.0, 2.0)],
             docs=["x acceleration [m/s^2]", "y acceleration [m/s^2]"])
    s.dynamics(f=[vx, vy, 0, 0], g=[[0, 0], [0, 0], [1, 0], [0, 1]])
    s.family("wall", lambda p: WALL_X - px, poles=[2.0, 2.0], doc="Left of the wall at px = 1 [m].")
    s.family("disc", lambda p: (px - DISC_CENTRE[0]) ** 2 + (py - DISC_CENTRE[1]) ** 2 - DISC_RADIUS**2,
             poles=[3.0, 3.0], doc="Outside the disc: squared distance minus squared radius [m^2].")
    s.objective(P=[[1 + vx**2, 2 * vx * vy], [2 * vx * vy, 1 + vy**2]], q=[0.5 * px, -0.3 * py],
                doc="Accelerations along the velocity cost more, the faster the robot moves.")
    return s
