"""A test spec: adaptive cruise control as a CLF-CBF problem (Ames et al., 2014; cbfpy's
example), with an extended class-K term.

States: the follower's speed v [m/s], the gap z to the lead car [m] and the lead's speed
v_lead [m/s] (constant); input the wheel force F [N], within +-0.3 m g. Rolling and air
resistance F_r(v) = f0 + f1 v + f2 v^2. Families: the headway
z - T_h v - (v_lead - v)^2 / (2 * 0.3 g) >= 0 (degree 1),
a standstill gap z - z_min >= 0 (degree 2, with alpha(s) = 10 tanh(s / 10) in its last term), and
the CLF V = (v - v_d)^2 that asks for the desired speed, below both.
"""

from __future__ import annotations

import symengine as se

from symbolic.spec import Positive, System

MASS = 1650.0  # kg
F0, F1, F2 = 0.1, 5.0, 0.25  # N, N s/m, N s^2/m^2
G = 9.81
TIME_HEADWAY = 1.8  # s
BRAKING = 0.3 * G  # m/s^2, the force limit's deceleration


def build() -> System:
    s = System("adaptive_cruise", doc="Adaptive cruise control: keep the headway, approach the desired speed.")
    v, z, v_lead = s.states(["v", "z", "v_lead"], docs=["speed [m/s]", "gap to the lead car [m]",
                                                        "the lead car's speed [m/s], constant"])
    s.inputs(["force"], limits=[(-0.3 * MASS * G, 0.3 * MASS * G)], docs=["wheel force [N]"])
    resistance = F0 + F1 * v + F2 * v**2
    s.dynamics(f=[-resistance / MASS, v_lead - v, 0], g=[[1 / MASS], [0], [0]])
    # Ames et al.'s headway: the time gap, and the distance braking at BRAKING needs to
    # match the lead's speed, so the row stays within the force limits.
    s.family("headway", lambda p: z - TIME_HEADWAY * v - (v_lead - v) ** 2 / (2 * BRAKING), poles=[1.0],
             doc="The gap covers TIME_HEADWAY seconds at the follower's speed and the braking to the "
                 "lead's speed [m].")
    s.family("standstill_gap", lambda p: z - p.z_min, params={"z_min": ((), "closest gap [m]", Positive)},
             defaults={"z_min": 5.0}, poles=[2.0, 2.0], class_k=lambda q: 10 * se.tanh(q / 10),
             doc="The gap never below z_min [m]; far from it, the approach rate capped by a tanh.")
    s.lyapunov("speed_goal", lambda p: (v - p.v_desired) ** 2, rate=2.0,
               params={"v_desired": ((), "desired speed [m/s]", Positive)}, defaults={"v_desired": 24.0},
               doc="V = (v - v_desired)^2 [m^2/s^2]: converge to the desired speed.")
    return s
