"""Built-in scenarios: Tachyon 3 on random staircases (the command line's campaign) and
the Panda arm among random obstacles."""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .scenario import Measure, Parameter, Row, Scenario, csv_field


# ------------------------------------------------------------------------- Tachyon 3
class TachyonStairs(Scenario):
    """Tachyon 3 climbing random staircases: ``cbfgen campaign`` as a scenario. Each shard
    runs in Rust (``threads`` threads per task), and the rows are its ``episodes.csv``
    lines, so :meth:`write` writes the command line's files (``merge_campaign``).

    ``ranges`` overrides the ``COURSE_RANGES`` (``[lo, hi]`` per ``rise``, ``run``,
    ``steps``, ``start_gap``, ``speed``); ``perception=True`` runs on perceived terrain."""

    name = "tachyon3 stairs"
    measures = (
        Measure("min_body_clearance", fails_below=-1e-3),
        Measure("min_toe_clearance", fails_below=-1e-3),
        Measure("min_toe_riser_clearance", fails_below=0.0),
        Measure("min_h_joint_limits", fails_below=-1e-4),
        Measure("relaxed_cycles", worse="higher", fails_above=0.0),
    )
    SAFETY_FAMILIES = ("joint_limits", "foot_height", "stability", "body_edge", "toe_edge", "foothold")
    """The barrier families whose relaxation is a safety verdict (``relaxed_cycles`` sums
    them; the foothold pull's relaxation is convergence, not safety)."""

    def __init__(
        self,
        ranges: Mapping[str, Sequence[float]] | None = None,
        body_cbf: bool = True,
        perception: bool = False,
        threads: int | None = 1,
    ) -> None:
        from .. import tachyon3 as t3

        merged = {k: list(v) for k, v in t3.COURSE_RANGES.items()}
        for key, value in (ranges or {}).items():
            if key not in merged:
                raise ValueError(f"no course range {key!r}; known: {', '.join(merged)}")
            merged[key] = list(value)
        self.ranges = merged
        self.timing_columns = tuple(t3.CAMPAIGN_TIMING_COLUMNS)
        self.body_cbf, self.perception, self.threads = body_cbf, perception, threads
        self.parameters = {
            k: Parameter(*merged[k], integer=k == "steps") for k in ("rise", "run", "steps", "start_gap", "speed")
        }
        t3.campaign(episodes=0, ranges=self.ranges)  # refuses ranges outside the domain now, not in a worker

    def _campaign(self, episodes: int, seed: int, first_id: int, ranges: Mapping[str, Sequence[float]]) -> list[Row]:
        from .. import tachyon3 as t3

        out = t3.campaign(
            episodes=episodes,
            seed=seed,
            first_id=first_id,
            body_cbf=self.body_cbf,
            threads=self.threads,
            ranges=dict(ranges),
            perception=self.perception,
        )
        return parse_rows(out["csv"])

    def run_ids(self, seed: int, first_id: int, count: int) -> list[Row]:
        # The Rust draw (ChaCha8 from seed and id), as the command line's: not Scenario.draw.
        return self._campaign(count, seed, first_id, self.ranges)

    def episode(self, params: Mapping[str, float | int], seed: int, episode_id: int) -> Row:
        # A campaign of one episode whose ranges hold one value each: exactly `params`.
        (row,) = self._campaign(1, seed, episode_id, {k: [params[k], params[k]] for k in self.parameters})
        return row

    def value(self, row: Row, measure: Measure) -> Any:
        if measure.column == "relaxed_cycles":
            return None if row["outcome"] == "error" else sum(row[f"relaxed_{f}"] for f in self.SAFETY_FAMILIES)
        return row.get(measure.column)

    def report(self, rows: Sequence[Row]) -> str:
        from .. import tachyon3 as t3

        return t3.merge_campaign([rows_csv(rows)])["report"]

    def write(self, rows: Sequence[Row], out: str | os.PathLike[str]) -> list[Path]:
        from .. import tachyon3 as t3

        return [Path(p) for p in t3.merge_campaign([rows_csv(rows)], os.fspath(out))["written"]]

    def replay(self, row: Row) -> str:
        ranges = " ".join(f"--{k.replace('_', '-')} {row[k]!r},{row[k]!r}" for k in self.parameters)
        flags = (" --no-body-cbf" if not self.body_cbf else "") + (" --perception" if self.perception else "")
        return f"cbfgen simulate --episode {row['id']} --seed {row['seed']} {ranges}{flags}"


_TEXT_COLUMNS = {"outcome", "body_nearest", "toe_nearest", "toe_riser_nearest", "error"}


def parse_rows(text: str) -> list[Row]:
    """``episodes.csv`` text (Tachyon 3's) as rows: integers and floats read back exactly,
    an empty number as None."""
    rows = []
    for record in csv.DictReader(io.StringIO(text)):
        row: Row = {}
        for key, value in record.items():
            if key in _TEXT_COLUMNS:
                row[key] = value
            elif value == "":
                row[key] = None
            else:
                number = float(value)
                row[key] = int(value) if number.is_integer() and "." not in value and "e" not in value else number
        rows.append(row)
    return rows


def rows_csv(rows: Sequence[Row]) -> str:
    """Rows back as ``episodes.csv`` text (the error column quoted), for ``merge_campaign``."""
    if not rows:
        raise ValueError("no rows")
    columns = list(rows[0])
    lines = [",".join(columns)]
    for r in rows:
        fields = [csv_field(r[c]) for c in columns[:-1]]
        error = r[columns[-1]]
        fields.append('"' + error.replace('"', '""') + '"' if r.get("outcome") == "error" else "")
        lines.append(",".join(fields))
    return "\n".join(lines) + "\n"


class ArmObstacles(Scenario):
    """Franka's Panda under its torque filter, its hand swept low among random sphere
    obstacles above a table (``cbfgen_panda_spheres``, docs/arm.md: OSCBF's setting).
    Parameters: how many obstacles (whole, within ``obstacles``) and the joints' cruise
    speed [rad/s]; the obstacles' layout is each episode's own randomness, drawn from
    ``(seed, id)`` (its ``layout_seed`` column). Clearances are exact distances between
    the arm's 21 spheres and the obstacles or the table (the model's geometry)."""

    name = "arm among obstacles"
    measures = (
        Measure("min_obstacle_clearance", fails_below=-1e-3),
        Measure("min_table_clearance", fails_below=-1e-3),
        Measure("fallback_cycles", worse="higher", fails_above=0.0),
    )
    timing_columns = ("median_cpu_us", "max_cpu_us")

    def __init__(
        self,
        obstacles: Sequence[int] = (5, 25),
        cruise_speed: Sequence[float] = (0.4, 1.2),
        duration: float = 10.0,
        filter: bool = True,
    ) -> None:
        from .. import _native

        lo, hi = obstacles
        if not 0 <= lo <= hi <= _native.ARM_MAX_OBSTACLES:
            raise ValueError(f"obstacles must be 0 <= lo <= hi <= {_native.ARM_MAX_OBSTACLES}, got {obstacles}")
        self.parameters = {"obstacles": Parameter(lo, hi, integer=True), "cruise_speed": Parameter(*cruise_speed)}
        self.duration, self.filter = float(duration), bool(filter)

    @staticmethod
    def layout_seed(seed: int, episode_id: int) -> int:
        """The seed of episode ``episode_id``'s obstacle layout, from ``(seed, id)``."""
        return int(np.random.SeedSequence([seed, episode_id]).generate_state(1, np.uint64)[0])

    def episode(self, params: Mapping[str, float | int], seed: int, episode_id: int) -> Row:
        from .. import _native

        layout = self.layout_seed(seed, episode_id)
        out = _native.arm_episode(
            obstacles=int(params["obstacles"]),
            seed=layout,
            duration=self.duration,
            cruise_speed=float(params["cruise_speed"]),
            filter=self.filter,
        )
        return {"layout_seed": layout, **out}

    def replay(self, row: Row) -> str:
        return (
            f"cbfgen._native.arm_episode(obstacles={row['obstacles']}, seed={row['layout_seed']}, "
            f"duration={self.duration!r}, cruise_speed={row['cruise_speed']!r}, filter={self.filter})"
        )
