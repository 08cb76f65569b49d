"""Run the Rust test binaries of a `cargo test` selection on every core at once.

``cargo test`` runs its test binaries one after another: a binary whose tests run on one
thread (a bench in test mode, one long closed loop) leaves the other cores idle, and on
the project's 2-core VM that was a third of the phase. This builds the selection as
``cargo test`` would (``--no-run``, the same arguments, so nothing is compiled again
after ``cargo build`` of the same targets), then runs the binaries ``--jobs`` at a time,
each exactly as cargo runs it (from its package's folder, with cargo's run-time
variables), the largest first so the longest-running binaries do not start last.

Each binary's output is printed whole when it ends, so the log reads binary by binary;
the exit status is 1 if any binary failed, and the failures are listed at the end.

    python scripts/test_binaries.py [--jobs N] CARGO_TEST_ARGS... [-- TEST_ARGS...]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class TestBinary:
    package: str
    target: str
    kind: str
    executable: Path
    manifest_dir: Path
    version: str

    @property
    def label(self) -> str:
        return f"{self.package} {self.kind} {self.target}"


def test_binaries(cargo_args: list[str]) -> list[TestBinary]:
    """Build the selection's test binaries and list them, from cargo's JSON messages."""
    done = subprocess.run(
        ["cargo", "test", *cargo_args, "--no-run", "--message-format=json-render-diagnostics"],
        stdout=subprocess.PIPE, text=True,
    )
    if done.returncode != 0:
        sys.exit(f"test_binaries: `cargo test --no-run` failed (exit {done.returncode})")
    found = []
    for line in done.stdout.splitlines():
        message = json.loads(line)
        if message.get("reason") != "compiler-artifact" or not message.get("executable"):
            continue
        if not message["profile"]["test"]:
            continue  # a binary built for another target to run (CARGO_BIN_EXE_*), not a test
        manifest = Path(message["manifest_path"])
        # package_id: "path+file:///…/name#version" or "…#name@version"
        tail = message["package_id"].rsplit("#", 1)[-1]
        name, _, version = tail.rpartition("@")
        found.append(TestBinary(
            package=name or manifest.parent.name,
            target=message["target"]["name"],
            kind=message["target"]["kind"][0],
            executable=Path(message["executable"]),
            manifest_dir=manifest.parent,
            version=version or tail,
        ))
    return found


def run_one(binary: TestBinary, test_args: list[str]) -> tuple[TestBinary, int, float, str]:
    # What cargo sets for a test it runs (the Cargo book, "Environment variables Cargo sets
    # for crates"): the package's folder, as working directory and as CARGO_MANIFEST_DIR.
    env = {
        **os.environ,
        "CARGO": shutil.which("cargo") or "cargo",
        "CARGO_MANIFEST_DIR": str(binary.manifest_dir),
        "CARGO_PKG_NAME": binary.package,
        "CARGO_PKG_VERSION": binary.version,
    }
    start = time.perf_counter()
    done = subprocess.run(
        [str(binary.executable), *test_args], cwd=binary.manifest_dir, env=env,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace",
    )
    return binary, done.returncode, time.perf_counter() - start, done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="test binaries at once (default: one per core)")
    args, rest = parser.parse_known_args()
    if args.jobs < 1:
        parser.error("--jobs must be at least 1")
    cargo_args, test_args = (rest[:rest.index("--")], rest[rest.index("--") + 1:]) if "--" in rest else (rest, [])

    binaries = test_binaries(cargo_args)
    # Largest first: the size of a test binary is a fair proxy for how much it runs, and a
    # long binary started last would run alone at the end.
    binaries.sort(key=lambda b: b.executable.stat().st_size, reverse=True)
    print(f"test_binaries: {len(binaries)} test binaries, {args.jobs} at a time", flush=True)
    failed = []
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        running = [pool.submit(run_one, b, test_args) for b in binaries]
        for finished in as_completed(running):
            binary, code, seconds, output = finished.result()
            verdict = "ok" if code == 0 else f"FAILED (exit {code})"
            print(f"\n== {binary.label}: {verdict} in {seconds:.1f} s\n{output.rstrip()}", flush=True)
            if code != 0:
                failed.append(binary.label)
    if failed:
        print("\ntest_binaries: failed: " + ", ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
