"""A scenario of your own for cbfgen.campaign: the double integrator (a built-in system;
yours loads with cbfgen.load) pushed down onto a floor through its ECBF filter, from a
start height and speed drawn per episode.

    python -m cbfgen.campaign run --scenario examples/campaign_floor.py:Floor --episodes 1000 --engine processes
    python -m cbfgen.campaign falsify --scenario examples/campaign_floor.py:LoosenedFloor --budget 200 --compare-uniform

Everything the campaign needs is declared here: the parameters (each drawn uniformly),
what an episode measures (with the value beyond which it failed), and one episode.
"""

from __future__ import annotations

import math

import cbfgen
import numpy as np
from cbfgen.campaign import Measure, Parameter, Scenario

DT = 1e-3


class Floor(Scenario):
    """Kept above q = 0 while a constant push drives it down; 0.5 s per episode."""

    name = "double integrator over a floor"
    parameters = {
        "start": Parameter(0.2, 1.0),  # height [m]
        "speed": Parameter(-2.0, 0.0),  # initial velocity [m/s]
        "push": Parameter(1.0, 10.0),  # nominal downward acceleration [m/s²]
    }
    measures = (
        Measure("lowest", fails_below=-1e-3),  # the floor is crossed by more than 1 mm
        Measure("not_qp_cycles", worse="higher", fails_above=0.0),  # an input not a QP optimum
    )

    def filter_floor(self, params):
        """Where the filter is told the floor is [m]: the true floor."""
        return 0.0

    def episode(self, params, seed, episode_id):
        system = cbfgen.System("double_integrator")
        floor = system.params()
        floor.set("sine_barrier", {"amplitude": 0.0, "omega": 0.0, "offset": self.filter_floor(params)})
        safety = system.filter()
        x, lowest, not_qp = np.array([params["start"], params["speed"]]), math.inf, 0
        for k in range(500):
            out = safety.update(x, [-params["push"]], floor, k * DT)
            not_qp += out.source != "qp"
            x = x + DT * system.xdot(x, out.u)
            lowest = min(lowest, float(x[0]))
        return {"lowest": lowest, "not_qp_cycles": not_qp}


class LoosenedFloor(Floor):
    """The same with a planted weakness for the falsifier to find: a loosened limit. The
    filter is told the floor is lower the harder the push and the faster the approach
    (2 cm times their product in unit scale over 0.8 below a 2 cm margin), so only the
    corner of hard push and fast approach goes more than 1 mm through the true floor."""

    name = "double integrator over a floor, limit loosened"

    def filter_floor(self, params):
        push = (params["push"] - 1.0) / 9.0
        approach = -params["speed"] / 2.0
        return 0.02 * (1.0 - push * approach / 0.8)
