"""A test spec: a planar quadrotor whose speed limit can starve its floor (issue 32).

States x, z [m], pitch theta [rad], their rates; inputs the mass-normalised thrust T
(0 to 2 g: a rotor pushes one way only) and the angular acceleration alpha. The speed limit
h = vmax^2 - vx^2 - vz^2 has relative degree 1 and acts only through T; the floor
h = z - z_floor has degree 2 and acts only through T too. Tilted and too fast, the speed
limit asks for less thrust than zero while the floor asks for more: the priorities decide.
"""

from __future__ import annotations

import symengine as se

from symbolic.spec import Positive, System

G = 9.81


def build() -> System:
    s = System("planar_quadrotor", doc="A planar quadrotor with a speed limit and a floor, both through thrust.")
    _, z, theta, vx, vz, _ = s.states(["x", "z", "theta", "vx", "vz", "omega"],
                                      docs=["x [m]", "height [m]", "pitch [rad]", "x velocity [m/s]",
                                            "vertical velocity [m/s]", "pitch rate [rad/s]"])
    s.inputs(["thrust", "alpha"], limits=[(0.0, 2.0 * G), (-10.0, 10.0)],
             docs=["mass-normalised thrust [m/s^2]", "angular acceleration [rad/s^2]"])
    s.dynamics(f=[vx, vz, s.x[5], 0, -G, 0],
               g=[[0, 0], [0, 0], [0, 0], [-se.sin(theta), 0], [se.cos(theta), 0], [0, 1]])
    s.family("speed_limit", lambda p: p.vmax**2 - vx**2 - vz**2,
             params={"vmax": ((), "speed limit [m/s]", Positive)}, poles=[5.0],
             doc="Speed below vmax: h = vmax^2 - |v|^2 [m^2/s^2].")
    s.family("floor", lambda p: z - p.z_floor, params={"z_floor": ((), "floor height [m]")}, poles=[4.0, 4.0],
             doc="Height above the floor [m].")
    return s
