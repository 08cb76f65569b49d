"""The edit loop as a measured figure: ``scripts/cbf edit-loop SYSTEM [--rounds N]``.

A user's first use of cbfgen is editing a model and running it again. This times exactly
that, for a built-in system: change one number in its spec (the SSAT sharpness
``SSAT_ALPHA``, a different value each round), rebuild its crate in release (the build
script regenerates the module from the spec, then rustc compiles it), and run the
crate's ``<system>_first_update`` example (one filter update from a fresh process). It prints
each round's generation, compile and run times, wall and CPU (the CPU of every child
process: Python, cargo, rustc), and restores the spec and its generated module
afterwards, whatever happens.

Everything else is built first (one untimed build), so a round measures what an edit
costs, not a cold build. The figures depend on the machine: compare them with one
measured in the same session.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# crate, the spec edited; every module of the crate is saved and restored. (ANYmal's
# whole-body and MPC specs read the robot from anymal_robot.py, not from the spec edited,
# and are generated in their own crate: an edit here regenerates and compiles the filter.)
SYSTEMS = {
    "panda": ("cbfgen-panda", ROOT / "systems/panda/spec/panda.py"),
    "anymal": ("cbfgen-anymal", ROOT / "systems/anymal/spec/anymal.py"),
}
KNOB = re.compile(r"^SSAT_ALPHA = ([0-9.]+)$", re.MULTILINE)


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed(command: list[str], quiet: bool = True) -> tuple[float, float, str]:
    """(wall s, CPU s of the command's processes, its stdout)."""
    cpu, wall = children_cpu(), time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - wall, children_cpu() - cpu
    if done.returncode != 0:
        sys.stderr.write(done.stdout + done.stderr)
        raise SystemExit(f"edit-loop: {' '.join(command)} failed (exit {done.returncode})")
    return wall, cpu, done.stdout


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="scripts/cbf edit-loop", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("system", choices=sorted(SYSTEMS))
    parser.add_argument("--rounds", type=int, default=3, help="edits to time (default 3)")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error("--rounds must be at least 1")
    crate, spec = SYSTEMS[args.system]
    generated = sorted((spec.parent.parent / "generated").glob("*.rs"))
    example = f"{args.system}_first_update"
    build = ["cargo", "build", "--release", "--quiet", "-p", crate, "--example", example]
    binary = ROOT / "target/release/examples" / example
    saved = {path: path.read_bytes() for path in [spec, *generated]}
    original = KNOB.search(saved[spec].decode())
    if original is None:
        raise SystemExit(f"edit-loop: {spec.relative_to(ROOT)} has no 'SSAT_ALPHA = <number>' line to edit")
    print(f"edit-loop: building {crate} once first (not timed)", file=sys.stderr)
    timed(build)
    rows = []
    try:
        for round_ in range(1, args.rounds + 1):
            alpha = float(original.group(1)) + 0.5 * round_
            spec.write_text(KNOB.sub(f"SSAT_ALPHA = {alpha}", saved[spec].decode(), count=1))
            build_wall, build_cpu, _ = timed(build)
            run_wall, run_cpu, out = timed([str(binary)])
            rows.append((round_, alpha, build_wall, build_cpu, run_wall, run_cpu, out.strip()))
            print(f"round {round_}: SSAT_ALPHA = {alpha}: rebuilt in {build_wall:.1f} s wall ({build_cpu:.1f} s CPU), "
                  f"ran in {run_wall:.2f} s; {out.strip()}", file=sys.stderr)
    finally:
        for path, text in saved.items():
            path.write_bytes(text)
    print(f"\nThe edit loop of {args.system} ({os.cpu_count()} cores): change SSAT_ALPHA in "
          f"{spec.relative_to(ROOT)}, cargo build --release -p {crate}, run its first update")
    print("| round | SSAT_ALPHA | regenerate + compile, wall / CPU [s] | first update, wall [s] | total wall [s] |")
    print("|---|---|---|---|---|")
    for round_, alpha, bw, bc, rw, _, _ in rows:
        print(f"| {round_} | {alpha} | {bw:.1f} / {bc:.1f} | {rw:.2f} | {bw + rw:.1f} |")
    totals = sorted(bw + rw for _, _, bw, _, rw, _, _ in rows)
    print(f"median total: {totals[len(totals) // 2]:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
