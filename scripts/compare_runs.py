"""Compare two simulation outputs column by column: ``python scripts/compare_runs.py OLD.csv NEW.csv [OLD2 NEW2 ...]``.

Prints the largest absolute difference over every numeric column except the timings
(``*_us``: wall and thread CPU time), and exits 1 when it exceeds ``--tolerance`` (default 1e-9) or when
headers, row counts or text columns differ. Used to show that a refactor leaves the
Tachyon 3 step and stairs runs unchanged (run both commits' ``cbfgen simulate``).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys


def _load(path: str) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def max_difference(old: str, new: str) -> float:
    """Largest |old - new| over the numeric, non-timing columns; raises ValueError on any
    structural difference."""
    head_old, rows_old = _load(old)
    head_new, rows_new = _load(new)
    if head_old != head_new or len(rows_old) != len(rows_new):
        raise ValueError(f"{old} vs {new}: headers or row counts differ")
    timing = {i for i, h in enumerate(head_old) if h.endswith("_us")}
    worst = 0.0
    for a, b in zip(rows_old, rows_new, strict=True):
        for i, (p, q) in enumerate(zip(a, b, strict=True)):
            if i in timing:
                continue
            try:
                x, y = float(p), float(q)
            except ValueError:
                if p != q:
                    raise ValueError(f"{old}: column {head_old[i]} differs: {p!r} vs {q!r}") from None
                continue
            if not (math.isnan(x) and math.isnan(y)):
                worst = max(worst, abs(x - y))
    return worst


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", help="pairs: OLD.csv NEW.csv ...")
    parser.add_argument("--tolerance", type=float, default=1e-9)
    args = parser.parse_args(argv)
    if len(args.files) % 2:
        parser.error("give the files in OLD NEW pairs")
    worst = 0.0
    for old, new in zip(args.files[::2], args.files[1::2], strict=True):
        difference = max_difference(old, new)
        print(f"{new}: max |difference| {difference:.3g}")
        worst = max(worst, difference)
    return 0 if worst <= args.tolerance else 1


if __name__ == "__main__":
    sys.exit(main())
