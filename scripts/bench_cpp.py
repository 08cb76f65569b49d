"""The C++ wrapper's filter update against Rust's, interleaved in one run.

Installs the double integrator for C++ (``cbfgen.embed``), builds ``capi/bench`` against it
with CMake, and alternates, round by round, the Rust criterion bench
``double_integrator/{update, update_type_erased, update_through_c_abi}``
(systems/double_integrator/benches/update.rs) with the C++ bench (capi/bench/
update_bench.cpp: the same update through ``cbfgen::Filter::update`` and ``u()``), so a
drift of the machine's speed falls on both alike. Prints each round, then the medians and
the ratios to Rust's typed update, with each process's CPU time beside its wall time.

    scripts/cbf bench-cpp [--rounds 5] [--seconds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUST_BENCHES = ("update", "update_type_erased", "update_through_c_abi")
UNITS = {"ps": 1e-3, "ns": 1.0, "µs": 1e3, "us": 1e3, "ms": 1e6, "s": 1e9}


def run_child(args: list[str]) -> tuple[str, float, float]:
    """Run ``args``; its output, wall seconds and CPU seconds (from wait4)."""
    start = time.perf_counter()
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    chunks = []
    assert process.stdout is not None
    for chunk in iter(lambda: process.stdout.read(65536), b""):
        chunks.append(chunk)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    output = b"".join(chunks).decode()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"bench_cpp: {args[0]} failed:\n{output}")
    return output, wall, usage.ru_utime + usage.ru_stime


def criterion_ns(output: str, name: str) -> float:
    """The middle estimate criterion printed for ``double_integrator/<name>``, in ns."""
    match = re.search(rf"double_integrator/{name}\s*\n\s*time:\s*\[\S+ \S+ (\S+) (\S+)", output)
    if not match:
        sys.exit(f"bench_cpp: no time for double_integrator/{name} in:\n{output}")
    return float(match.group(1)) * UNITS[match.group(2)]


def build(prefix: Path, build_dir: Path) -> tuple[Path, Path]:
    """The C++ bench and the Rust bench binaries, built."""
    python = sys.executable
    subprocess.run([python, "-m", "cbfgen.embed", "install", "--quiet", "--prefix", str(prefix), "double_integrator"],
                   check=True, cwd=ROOT)
    cmake = str(Path(python).parent / "cmake")
    subprocess.run([cmake, "-S", str(ROOT / "capi" / "bench"), "-B", str(build_dir), f"-DCMAKE_PREFIX_PATH={prefix}",
                    "-DCMAKE_BUILD_TYPE=Release"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run([cmake, "--build", str(build_dir)], check=True, stdout=subprocess.DEVNULL)
    listed = subprocess.run(["cargo", "bench", "--no-run", "--message-format=json", "-p", "cbfgen-double-integrator",
                             "--bench", "update"], check=True, cwd=ROOT, capture_output=True, text=True).stdout
    rust = next(json.loads(line)["executable"] for line in listed.splitlines()
                if '"executable":"' in line and json.loads(line).get("target", {}).get("name") == "update")
    return build_dir / "update_bench", Path(rust)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="Rust and C++ runs each (default 5)")
    parser.add_argument("--seconds", type=float, default=3.0, help="criterion's measurement time per bench")
    args = parser.parse_args()
    work = ROOT / "target" / "bench-cpp"
    cpp, rust = build(work / "prefix", work / "build")
    pattern = "double_integrator/(" + "|".join(RUST_BENCHES) + ")$"
    rows = []
    names = (*RUST_BENCHES, "C++ Filter::update")
    print(f"{'round':>5}  " + "  ".join(f"{n:>22}" for n in names) + "  (ns per update)")
    for round_ in range(args.rounds):
        out, rust_wall, rust_cpu = run_child([str(rust), "--bench", "--warm-up-time", "1", "--measurement-time",
                                              str(args.seconds), "--noplot", pattern])
        rust_ns = [criterion_ns(out, name) for name in RUST_BENCHES]
        out, cpp_wall, cpp_cpu = run_child([str(cpp), "31", "200000"])
        cpp_ns = float(re.search(r"wall=(\S+)", out).group(1))
        cpp_thread_cpu = float(re.search(r"cpu=(\S+)", out).group(1))
        rows.append([*rust_ns, cpp_ns])
        print(f"{round_ + 1:>5}  " + "  ".join(f"{v:>22.1f}" for v in rows[-1])
              + f"  (processes: Rust {rust_wall:.1f} s wall / {rust_cpu:.1f} s CPU, C++ {cpp_wall:.1f} s / "
              f"{cpp_cpu:.1f} s; C++ thread CPU {cpp_thread_cpu:.1f} ns per update)")
    medians = [statistics.median(column) for column in zip(*rows, strict=True)]
    print(f"{'median':>5}  " + "  ".join(f"{v:>22.1f}" for v in medians))
    typed = medians[0]
    for name, value in zip((*RUST_BENCHES[1:], "C++ Filter::update"), medians[1:], strict=True):
        print(f"{name}: {value / typed:.3f} x Rust's typed update")


if __name__ == "__main__":
    main()
