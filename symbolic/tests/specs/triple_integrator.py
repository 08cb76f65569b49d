"""A test spec: the triple integrator p''' = u under a position limit (relative degree 3)."""

from __future__ import annotations

from symbolic.spec import System


def build() -> System:
    s = System("triple_integrator", doc="The triple integrator p''' = u below a position limit.")
    p, v, a = s.states(["p", "v", "a"], docs=["position [m]", "velocity [m/s]", "acceleration [m/s^2]"])
    s.inputs(["jerk"], limits=[(-50.0, 50.0)], docs=["jerk [m/s^3]"])
    s.dynamics(f=[v, a, 0], g=[[0], [0], [1]])
    s.family("position_limit", lambda prm: prm.p_max - p, params={"p_max": ((), "position limit [m]")},
             poles=[3.0, 4.0, 5.0], doc="Position below p_max: h = p_max - p [m].")
    return s
