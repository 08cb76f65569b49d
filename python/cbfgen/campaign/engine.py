"""Campaigns on an engine: episodes cut into contiguous shards of ids, run in this
process, on a :class:`concurrent.futures.Executor` or on Ray, and merged in id order."""

from __future__ import annotations

import concurrent.futures
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .scenario import Row, Scenario

Engine = None | str | concurrent.futures.Executor
"""Where shards run: ``None`` (this process, one shard after another), an
:class:`~concurrent.futures.Executor`, or ``"ray"`` (a local Ray instance, started on
first use and kept for the process) or a Ray address (``"auto"``, ``"ray://host:10001"``)."""

Progress = Callable[[int, int], None]
"""Called as shards finish, with (episodes done, episodes in all)."""


# ------------------------------------------------------------------------- shards, engines
def shard_blocks(first_id: int, episodes: int, shards: int) -> list[tuple[int, int]]:
    """``(first id, count)`` of each of ``shards`` contiguous blocks covering ``first_id ..
    first_id + episodes``: shard ``i`` starts at ``first_id + i * episodes // shards``, as
    ``cbfgen campaign --shard i/N`` does (``CampaignSettings::shard``)."""
    if not 1 <= shards <= episodes:
        raise ValueError(f"shards must be from 1 to the {episodes} episodes, got {shards}")
    start = [first_id + i * episodes // shards for i in range(shards + 1)]
    return [(start[i], start[i + 1] - start[i]) for i in range(shards)]


def _task(task: tuple) -> list[Row]:
    """One shard of work, where the engine runs it: a block of ids, or explicit points."""
    kind, scenario, seed, first, what = task
    if kind == "ids":
        return scenario.run_ids(seed, first, what)
    return scenario.run_points(what, seed, first)


def worker_count(engine: Engine) -> int:
    """How many tasks the engine runs at once (for the default shard count)."""
    if engine is None:
        return 1
    if isinstance(engine, str):
        return max(1, int(_ray(engine).cluster_resources().get("CPU", 1)))
    return int(getattr(engine, "_max_workers", None) or os.cpu_count() or 1)


def _ray(address: str):
    """Ray, connected: to ``address``, or a local instance for ``"ray"``; an instance
    already up (``ray.init`` by the caller) is used as it is."""
    try:
        import ray
    except ImportError as missing:  # pragma: no cover - the message is the point
        raise ImportError("the Ray engine needs Ray: pip install -r python/requirements.txt") from missing
    if not ray.is_initialized():
        ray.init(address=None if address == "ray" else address, include_dashboard=False, log_to_driver=False)
    return ray


def map_tasks(engine: Engine, tasks: list[tuple], done: Callable[[int], None] | None = None) -> list[list[Row]]:
    """Every task's rows, in task order; ``done(k)`` as task ``k`` finishes."""
    results: list[list[Row] | None] = [None] * len(tasks)

    def finished(k: int, rows: list[Row]) -> None:
        results[k] = rows
        if done is not None:
            done(k)

    if engine is None:
        for k, task in enumerate(tasks):
            finished(k, _task(task))
    elif isinstance(engine, str):
        ray = _ray(engine)
        remote = ray.remote(num_cpus=1)(_task)
        index = {remote.remote(task): k for k, task in enumerate(tasks)}
        pending = list(index)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for ref in ready:
                finished(index[ref], ray.get(ref))
    elif isinstance(engine, concurrent.futures.Executor):
        futures = {engine.submit(_task, task): k for k, task in enumerate(tasks)}
        for future in concurrent.futures.as_completed(futures):
            finished(futures[future], future.result())
    else:
        raise TypeError(f"engine is None, 'ray', a Ray address or a concurrent.futures.Executor, got {engine!r}")
    return results  # type: ignore[return-value]  # every task has finished


def _merged(parts: list[list[Row]]) -> list[Row]:
    """Shards' rows in id order; an id in two shards is an error."""
    rows = sorted((r for part in parts for r in part), key=lambda r: r["id"])
    for a, b in zip(rows, rows[1:], strict=False):
        if a["id"] == b["id"]:
            raise ValueError(f"episode {a['id']} is in two shards")
    return rows


# ---------------------------------------------------------------------------- campaigns
@dataclass
class Campaign:
    """A campaign's rows (id order) and how it ran."""

    scenario: Scenario
    seed: int
    rows: list[Row]
    seconds: float
    """Wall time of the whole run [s]."""
    engine: str
    shards: int

    def column(self, name: str) -> np.ndarray:
        """One column over the episodes (NaN where missing)."""
        return np.array([np.nan if r.get(name) is None else r[name] for r in self.rows], dtype=float)

    def failures(self, measure: str | None = None) -> list[int]:
        """Ids of the episodes that failed ``measure`` (the first when None)."""
        m = self.scenario.measure(measure)
        return [r["id"] for r in self.rows if self.scenario.failed(r, m)]

    def report(self) -> str:
        """The scenario's report of the rows."""
        return self.scenario.report(self.rows)

    def write(self, out: str | os.PathLike[str]) -> list[Path]:
        """The scenario's files for the rows (``episodes.csv``, ``report.txt``, ...)."""
        return self.scenario.write(self.rows, out)


def _engine_name(engine: Engine) -> str:
    if engine is None:
        return "this process"
    if isinstance(engine, str):
        return f"Ray ({engine})"
    return type(engine).__name__


def run_campaign(
    scenario: Scenario,
    episodes: int,
    *,
    seed: int = 0,
    first_id: int = 0,
    engine: Engine = None,
    shards: int | None = None,
    progress: Progress | None = None,
) -> Campaign:
    """Episodes ``first_id .. first_id + episodes`` of ``scenario`` and ``seed``, cut into
    ``shards`` contiguous blocks (default: one in this process, four per worker on an
    engine) run on ``engine``, merged in id order. ``progress(done, episodes)`` is called
    as shards finish. The rows do not depend on the engine or the shard count."""
    for what, v, lo in (("episodes", episodes, 1), ("seed", seed, 0), ("first_id", first_id, 0)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < lo:
            raise ValueError(f"{what} must be an integer >= {lo}, got {v!r}")
    if shards is None:
        shards = 1 if engine is None else min(episodes, 4 * worker_count(engine))
    blocks = shard_blocks(first_id, episodes, shards)
    tasks = [("ids", scenario, seed, first, count) for first, count in blocks]
    done = [0]

    def shard_done(k: int) -> None:
        done[0] += blocks[k][1]
        if progress is not None:
            progress(done[0], episodes)

    started = time.perf_counter()
    rows = _merged(map_tasks(engine, tasks, shard_done))
    return Campaign(scenario, seed, rows, time.perf_counter() - started, _engine_name(engine), shards)
