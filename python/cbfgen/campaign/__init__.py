"""Safety campaigns and falsification for any system, on one machine or many.

A :class:`Scenario` says what an episode is: its parameters (each drawn uniformly from a
range), how to run one episode at given parameters, and what it measures (the smallest
clearance, the deepest joint-limit row, the cycles with safety relaxed), each with the
value beyond which an episode has failed. On any scenario:

* :func:`run_campaign` runs episodes ``first_id .. first_id + episodes`` of a seed. Each
  episode is drawn from ``(seed, id)`` alone, so the episodes can be cut into contiguous
  shards and run anywhere: in this process, on any :class:`concurrent.futures.Executor`
  (a process pool, a Dask cluster's ``client.get_executor()``), or on Ray (a local instance, or a cluster by
  address). The shards are merged in id order into one :class:`Campaign`, with the same
  rows whatever ran them.
* :func:`falsify` searches the parameters for the worst outcome with CMA-ES (the ``cma``
  package). It then estimates the failure probability under the scenario's own uniform
  distribution by importance sampling around what it found, with a 95 % confidence
  interval.

Built in: :class:`TachyonStairs`, the command line's campaign (true or perceived
terrain), whose files are those ``cbfgen campaign`` writes. For a system of your own,
subclass :class:`Scenario`, declare ``parameters`` and ``measures``, and write
:meth:`Scenario.episode`:

>>> import numpy as np
>>> import cbfgen
>>> from cbfgen.campaign import Measure, Parameter, Scenario, run_campaign
>>> class Floor(Scenario):
...     '''The double integrator pushed down onto the floor q = 0 through its filter.'''
...     name = "floor"
...     parameters = {"start": Parameter(0.1, 1.0), "push": Parameter(1.0, 10.0)}
...     measures = (Measure("lowest", fails_below=-1e-3),)
...     def episode(self, params, seed, episode_id):
...         system = cbfgen.System("double_integrator")
...         barrier = system.params()
...         barrier.set("sine_barrier", {"amplitude": 0.0, "omega": 0.0, "offset": 0.0})
...         safety, x, lowest = system.filter(), np.array([params["start"], 0.0]), np.inf
...         for k in range(300):
...             u = safety.update(x, [-params["push"]], barrier, k * 1e-3).u
...             x = x + 1e-3 * system.xdot(x, u)
...             lowest = min(lowest, x[0])
...         return {"lowest": lowest}
>>> campaign = run_campaign(Floor(), episodes=4, seed=1)
>>> [row["id"] for row in campaign.rows], campaign.failures("lowest")
([0, 1, 2, 3], [])
"""

from .engine import Campaign, Engine, Progress, run_campaign, shard_blocks
from .falsifier import Falsification, falsify
from .scenario import Measure, Parameter, Row, Scenario
from .scenarios import ArmObstacles, TachyonStairs, parse_rows, rows_csv

__all__ = [
    "ArmObstacles",
    "Campaign",
    "Engine",
    "Falsification",
    "Measure",
    "Parameter",
    "Progress",
    "Row",
    "Scenario",
    "TachyonStairs",
    "falsify",
    "parse_rows",
    "rows_csv",
    "run_campaign",
    "shard_blocks",
]
