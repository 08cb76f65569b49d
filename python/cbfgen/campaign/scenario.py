"""The scenario interface: what an episode is (its parameters, drawn uniformly from
ranges), how one runs, and what it measures, each measure with the value beyond which an
episode has failed."""

from __future__ import annotations

import csv
import io
import math
import numbers
import os
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

Row = dict[str, Any]


# ------------------------------------------------------------------ the scenario interface
@dataclass(frozen=True)
class Parameter:
    """A parameter drawn uniformly from ``[lo, hi]``; with ``integer=True`` a whole number
    from ``lo`` to ``hi``, each equally likely."""

    lo: float
    hi: float
    integer: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lo) and math.isfinite(self.hi) and self.lo <= self.hi):
            raise ValueError(f"a parameter needs finite lo <= hi, got [{self.lo}, {self.hi}]")
        if self.integer and (self.lo != int(self.lo) or self.hi != int(self.hi)):
            raise ValueError(f"an integer parameter needs whole bounds, got [{self.lo}, {self.hi}]")

    def value(self, u: float) -> float | int:
        """The value at ``u`` in [0, 1] of the unit interval that maps uniformly onto it."""
        u = min(max(float(u), 0.0), 1.0)
        if self.integer:
            span = int(self.hi) - int(self.lo)
            return int(self.lo) + min(int(u * (span + 1)), span)
        return self.lo + u * (self.hi - self.lo)


@dataclass(frozen=True)
class Measure:
    """What an episode measured, by its column: smaller is worse (a clearance), or larger
    with ``worse="higher"`` (cycles relaxed). The episode failed when the value is below
    ``fails_below`` (smaller is worse) or above ``fails_above``. A missing or non-finite
    value (no contact at all) is the best possible."""

    column: str
    worse: str = "lower"
    fails_below: float | None = None
    fails_above: float | None = None

    def __post_init__(self) -> None:
        if self.worse not in ("lower", "higher"):
            raise ValueError(f"worse is 'lower' or 'higher', got {self.worse!r}")
        threshold = self.fails_below if self.worse == "lower" else self.fails_above
        other = self.fails_above if self.worse == "lower" else self.fails_below
        if threshold is None or other is not None or not math.isfinite(threshold):
            side = "fails_below" if self.worse == "lower" else "fails_above"
            raise ValueError(f"measure {self.column!r} ({self.worse} is worse) needs a finite {side} and no other")

    def badness(self, value: Any) -> float:
        """The value oriented so that smaller is worse; +inf when missing or not finite."""
        if value is None or not isinstance(value, numbers.Real) or not math.isfinite(value):
            return math.inf
        return float(value) if self.worse == "lower" else -float(value)

    def failed(self, value: Any) -> bool:
        """Whether ``value`` is beyond the failure threshold."""
        threshold = self.fails_below if self.worse == "lower" else -self.fails_above  # type: ignore[operator]
        return self.badness(value) < threshold


class Scenario(ABC):
    """One kind of episode: a system, a task and what to measure. Subclasses set
    ``parameters`` (name to :class:`Parameter`), ``measures`` (the first is the default
    for :func:`falsify`) and ``name``, and write :meth:`episode`. Instances must pickle
    (their state is settings, not a running simulation), so that engines can ship them."""

    name: str = "scenario"
    parameters: Mapping[str, Parameter] = {}
    measures: Sequence[Measure] = ()
    timing_columns: tuple[str, ...] = ()
    """Columns that depend on the machine and the moment, not on the episode."""

    @abstractmethod
    def episode(self, params: Mapping[str, float | int], seed: int, episode_id: int) -> Row:
        """Run one episode at ``params`` (its own randomness, if any, from ``(seed,
        episode_id)``) and return what it measured, one value per column."""

    # --- drawing and running; override for a faster batch path
    def draw(self, seed: int, episode_id: int) -> dict[str, float | int]:
        """Episode ``episode_id``'s parameters, uniform over their ranges, from ``(seed,
        episode_id)`` alone."""
        u = np.random.default_rng([seed, episode_id]).random(len(self.parameters))
        return {name: p.value(v) for (name, p), v in zip(self.parameters.items(), u, strict=True)}

    def run_ids(self, seed: int, first_id: int, count: int) -> list[Row]:
        """Episodes ``first_id .. first_id + count`` of campaign ``seed``, in id order."""
        rows = []
        for i in range(first_id, first_id + count):
            params = self.draw(seed, i)
            rows.append({"id": i, "seed": seed, **params, **self.episode(params, seed, i)})
        return rows

    def run_points(self, points: Sequence[Mapping[str, float | int]], seed: int, first_id: int) -> list[Row]:
        """Episodes at the given parameters (a falsifier's), numbered from ``first_id``."""
        return [
            {"id": first_id + k, "seed": seed, **p, **self.episode(p, seed, first_id + k)} for k, p in enumerate(points)
        ]

    # --- what a campaign leaves
    def measure(self, column: str | None = None) -> Measure:
        """The measure of ``column`` (the first measure when None)."""
        if not self.measures:
            raise ValueError(f"scenario {self.name!r} declares no measures")
        if column is None:
            return self.measures[0]
        for m in self.measures:
            if m.column == column:
                return m
        known = ", ".join(m.column for m in self.measures)
        raise ValueError(f"scenario {self.name!r} has no measure {column!r}; known: {known}")

    def report(self, rows: Sequence[Row]) -> str:
        """A table: episodes, and per measure the failures and the worst episode."""
        lines = [f"| {self.name}: episodes | {len(rows)} |", "|---|---|"]
        for m in self.measures:
            failed = [r["id"] for r in rows if self.failed(r, m)]
            worst = self.worst(rows, m)
            beyond = f"< {m.fails_below}" if m.worse == "lower" else f"> {m.fails_above}"
            lines.append(f"| {m.column} {beyond} (failed) | {len(failed)} |")
            if worst:
                lines.append(f"| worst {m.column} | {self.value(worst[0], m)} (episode {worst[0]['id']}) |")
        return "\n".join(lines)

    def write(self, rows: Sequence[Row], out: str | os.PathLike[str]) -> list[Path]:
        """Write ``episodes.csv`` (one line per row) and ``report.txt`` into ``out``."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        columns = list(dict.fromkeys(key for r in rows for key in r))
        text = io.StringIO()
        writer = csv.DictWriter(text, columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows({k: csv_field(v) for k, v in r.items()} for r in rows)
        (out / "episodes.csv").write_text(text.getvalue())
        (out / "report.txt").write_text(self.report(rows) + "\n")
        return [out / "episodes.csv", out / "report.txt"]

    def replay(self, row: Row) -> str:
        """How to run ``row``'s episode again."""
        params = {name: row[name] for name in self.parameters}
        return f"{type(self).__name__}(...).episode({params!r}, seed={row['seed']}, episode_id={row['id']})"

    def value(self, row: Row, measure: Measure) -> Any:
        """``row``'s value of ``measure`` (its column; override for a derived measure)."""
        return row.get(measure.column)

    def failed(self, row: Row, measure: Measure) -> bool:
        """Whether ``row`` failed ``measure``."""
        return measure.failed(self.value(row, measure))

    def worst(self, rows: Sequence[Row], measure: Measure, k: int = 1) -> list[Row]:
        """The ``k`` worst of ``rows`` by ``measure``, worst first."""
        return sorted(rows, key=lambda r: measure.badness(self.value(r, measure)))[:k]


def csv_field(value: Any) -> str:
    """A CSV field: every number as a number whatever its type (NumPy's scalars too),
    each real at full precision (it reads back the same); None, inf and NaN empty."""
    if value is None:
        return ""
    if isinstance(value, bool | np.bool_):
        return str(bool(value))
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        value = float(value)
        return repr(value) if math.isfinite(value) else ""
    return str(value)
