"""The falsifier: CMA-ES over a scenario's parameters for its worst outcome, then an
importance-sampling estimate of the failure probability around what it found."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .engine import Engine, Progress, map_tasks, worker_count
from .scenario import Measure, Row, Scenario


# ---------------------------------------------------------------------------- falsifier
@dataclass
class Falsification:
    """What :func:`falsify` found and estimated."""

    scenario: Scenario
    measure: Measure
    search: list[Row]
    """The search's episodes, in the order run."""
    sampled: list[Row]
    """The importance-sampling episodes."""
    weights: np.ndarray
    """Each sampled episode's likelihood ratio, nominal over proposal."""
    probability: float
    """Estimated failure probability under the scenario's uniform distribution."""
    interval: tuple[float, float]
    """Its 95 % confidence interval."""
    first_failure: int | None
    """How many episodes the search ran up to and including its first failure."""
    seconds: float
    box: list[tuple[float, float]] = field(default_factory=list)
    """The last stage's proposal box, per parameter, in the unit cube."""

    def worst(self, k: int = 5) -> list[Row]:
        """The ``k`` worst episodes run (search and sampling), worst first."""
        return self.scenario.worst(self.search + self.sampled, self.measure, k)

    def report(self, k: int = 5) -> str:
        m = self.measure
        lines = [
            f"falsifier on {self.scenario.name}, measure {m.column} ({m.worse} is worse)",
            f"search: {len(self.search)} episodes (CMA-ES); first failure at episode "
            + ("-" if self.first_failure is None else str(self.first_failure)),
            f"importance sampling: {len(self.sampled)} episodes; failure probability "
            f"{self.probability:.3g} (95 % CI {self.interval[0]:.3g} to {self.interval[1]:.3g})",
            f"{self.seconds:.1f} s",
            "worst episodes:",
        ]
        for r in self.worst(k):
            lines.append(f"  {m.column} = {self.scenario.value(r, m)}: {self.scenario.replay(r)}")
        return "\n".join(lines)


def falsify(
    scenario: Scenario,
    measure: str | None = None,
    *,
    budget: int = 200,
    seed: int = 0,
    engine: Engine = None,
    search_share: float = 0.5,
    defensive: float = 0.2,
    spread: float = 0.2,
    sigma0: float = 0.3,
    progress: Progress | None = None,
) -> Falsification:
    """Hunt for the worst episode of ``scenario`` by ``measure`` (its first when None)
    within ``budget`` episodes, then estimate how likely a failure is.

    1. **Search** (``search_share`` of the budget): CMA-ES (``cma``) over the parameters
       mapped onto the unit cube, each generation's episodes run on ``engine``.
    2. **Estimate** (the rest, in two stages): importance sampling under a *defensive*
       proposal ``q = defensive · uniform + (1 − defensive) · box``. In ``box`` each
       parameter is drawn on its own from the box around the failures found so far (the
       worst tenth if fewer than three; padded by a quarter of its width), or with chance
       ``spread`` from its whole range, so a parameter the failures never spread over is
       still covered. The whole cube's share keeps every weight ``p / q`` (``p`` uniform
       on the cube) at most ``1 / defensive``, so a failure region broader than the box
       is still counted at a bounded weight. The second stage's box takes in the first
       stage's failures. The estimate is the mean weighted failure with a normal 95 %
       interval; with no failure sampled, the upper end is ``3 / (defensive · n)`` (the
       rule of three on ``q``, times the largest weight), at most 1. The estimate is
       unbiased whatever the box; the interval assumes the weighted failures' spread is
       seen, which a failure region that neither the box nor a few of the cube's draws
       touched defeats (then it is too narrow).
    """
    import cma

    if not isinstance(budget, int) or budget < 4:
        raise ValueError(f"budget must be an integer >= 4, got {budget!r}")
    shares = (search_share, defensive, spread)
    if not all(0.0 < v < 1.0 for v in shares) or not 0.0 < sigma0 <= 1.0:
        raise ValueError(
            f"search_share, defensive and spread must be in (0, 1), sigma0 in (0, 1]; got {shares}, {sigma0}"
        )
    m = scenario.measure(measure)
    names, params = list(scenario.parameters), list(scenario.parameters.values())
    if len(names) < 2:
        raise ValueError("the falsifier searches two parameters or more (CMA-ES's smallest space)")
    started = time.perf_counter()
    to_params = lambda u: {n: p.value(v) for n, p, v in zip(names, params, u, strict=True)}  # noqa: E731
    done = [0]

    def run(points: list[np.ndarray]) -> list[Row]:
        chunks = _chunks(len(points), worker_count(engine))
        tasks = [("points", scenario, seed, done[0] + a, [to_params(u) for u in points[a:b]]) for a, b in chunks]
        rows = [r for part in map_tasks(engine, tasks) for r in part]
        done[0] += len(points)
        if progress is not None:
            progress(done[0], budget)
        return rows

    search_budget = max(2, int(budget * search_share))
    es = cma.CMAEvolutionStrategy([0.5] * len(names), sigma0, {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9})
    search: list[Row] = []
    units: list[np.ndarray] = []
    while len(search) < search_budget:
        points = [np.asarray(u, dtype=float) for u in es.ask()][: search_budget - len(search)]
        rows = run(points)
        search += rows
        units += points
        if len(points) < es.popsize:
            break
        # CMA-ES needs finite values: a missing one (no contact) ranks behind every finite.
        values = [m.badness(scenario.value(r, m)) for r in rows]
        finite = [v for v in values if math.isfinite(v)]
        ceiling = (max(finite) + 1.0 + abs(max(finite))) if finite else 1.0
        es.tell(points, [v if math.isfinite(v) else ceiling for v in values])
    failed = [scenario.failed(r, m) for r in search]
    first_failure = failed.index(True) + 1 if any(failed) else None

    # Importance sampling in stages: each stage's box spans the failures found so far
    # (or, with fewer than three, the worst tenth), padded; each sample keeps the weight
    # of the proposal it was drawn from, so every stage's terms are unbiased and the
    # estimate is their mean.
    n = budget - len(search)
    rng = np.random.default_rng([seed, 2])
    known = list(zip(units, search, strict=True))
    sampled, weights, boxes = [], [], []
    for size in (n // 2, n - n // 2)[: 2 if n >= 2 else n]:
        lo, hi = _failure_box(known, scenario, m)
        boxes.append((lo, hi))
        # The whole cube with chance `defensive`; else each parameter on its own from the
        # box, or (with chance `spread`) from its whole range.
        d = len(names)
        from_box = (rng.random((size, 1)) >= defensive) & (rng.random((size, d)) >= spread)
        samples = np.where(from_box, lo + rng.random((size, d)) * (hi - lo), rng.random((size, d)))
        inside = (samples >= lo) & (samples <= hi)
        box_density = np.prod(spread + (1.0 - spread) * inside / (hi - lo), axis=1)
        weights.append(1.0 / (defensive + (1.0 - defensive) * box_density))
        rows = run(list(samples))
        sampled += rows
        known += list(zip(samples, rows, strict=True))
    weights = np.concatenate(weights) if weights else np.zeros(0)
    hits = np.array([scenario.failed(r, m) for r in sampled], dtype=float)
    terms = weights * hits
    probability = float(terms.mean()) if n else math.nan
    if n > 1 and hits.any():
        half = 1.96 * float(terms.std(ddof=1)) / math.sqrt(n)
        interval = (max(0.0, probability - half), probability + half)
    else:
        interval = (0.0, min(1.0, 3.0 / (defensive * n)) if n else 1.0)
    lo, hi = boxes[-1] if boxes else (np.zeros(len(names)), np.ones(len(names)))
    return Falsification(
        scenario,
        m,
        search,
        sampled,
        weights,
        probability,
        interval,
        first_failure,
        time.perf_counter() - started,
        list(zip(lo.tolist(), hi.tolist(), strict=True)),
    )


def _failure_box(known: list[tuple[np.ndarray, Row]], scenario: Scenario, m: Measure) -> tuple[np.ndarray, np.ndarray]:
    """The unit-cube box around the points of ``known`` that failed ``m`` (the worst
    tenth, at least three, when fewer than three failed), padded by a quarter of its width
    (at least 0.02) on each side."""
    elite = [u for u, r in known if scenario.failed(r, m)]
    if len(elite) < 3:
        ranked = sorted(known, key=lambda item: m.badness(scenario.value(item[1], m)))
        elite = [u for u, _ in ranked[: max(3, len(ranked) // 10)]]
    points = np.array(elite)
    pad = np.maximum(0.25 * (points.max(axis=0) - points.min(axis=0)), 0.02)
    return np.clip(points.min(axis=0) - pad, 0.0, 1.0), np.clip(points.max(axis=0) + pad, 0.0, 1.0)


def _chunks(count: int, workers: int) -> list[tuple[int, int]]:
    """``[a, b)`` index ranges cutting ``count`` items into one chunk per worker."""
    pieces = max(1, min(count, workers))
    edges = [i * count // pieces for i in range(pieces + 1)]
    return [(edges[i], edges[i + 1]) for i in range(pieces) if edges[i + 1] > edges[i]]
