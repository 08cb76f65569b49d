"""The double integrator q'' = u under a moving lower bound: the multi-layer safety example.

State x = [q, q'], input u. The safe set is time-varying: q must stay above the sinusoid
s(t) = A sin(w t) + c, so

    h(x, t) = q - s(t),

with A, w and c runtime parameters and t a clock for the Lie engine (t' = 1):

    L_f h   = q' - A w cos(w t)
    L_f^2 h = A w^2 sin(w t)           (and L_g L_f h = 1: relative degree 2)

The same mathematics as ``symbolic/families/double_integrator.py`` (which this spec is to
replace): the boundary is a named intermediate, so the clock's rate goes through it the
way a moving obstacle's pose would.

The input limit is the runtime's largest, +-1e6 m/s^2: the multi-layer example bounds
nothing by default (its ``u_max`` is infinite), and a user narrows the limits in the
filter settings.
"""

from __future__ import annotations

import symengine as se

from symbolic.spec import MAX_INPUT, System


def build() -> System:
    s = System("double_integrator",
               doc="The double integrator q'' = u above the moving boundary A sin(w t) + c "
                   "(the multi-layer safety example).")
    q, qd = s.states(["q", "qd"], docs=["position [m]", "velocity [m/s]"])
    s.inputs(["u"], limits=[(-MAX_INPUT, MAX_INPUT)], docs=["acceleration [m/s^2]"])
    s.dynamics(f=[qd, 0], g=[[0], [1]])

    def above_sine(p):
        boundary = p.let("boundary", p.amplitude * se.sin(p.omega * p.t) + p.offset)
        return [("above_sine", q - boundary)]

    s.family("sine_barrier", above_sine,
             params={"amplitude": ((), "amplitude A of the boundary [m]"),
                     "omega": ((), "angular frequency w of the boundary [rad/s]"),
                     "offset": ((), "offset c of the boundary [m]")},
             count=1, time=True, poles=[10.0, 10.0],
             doc="The position above the moving boundary: h = q - A sin(w t) - c, with the "
                 "boundary's time derivatives.")
    return s
