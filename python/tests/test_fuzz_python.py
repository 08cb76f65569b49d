"""scripts/fuzz_python.py cannot rot: a short campaign runs through every category and
every built-in system and finds nothing, and the
harness attributes each kind of finding (abort, hang, panic, non-finite output) to the case
that caused it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

FUZZ = Path(__file__).resolve().parents[2] / "scripts" / "fuzz_python.py"
# Only a hang detector for the harness itself; a campaign of a few hundred cases takes
# seconds.
HARNESS_TIMEOUT_S = 300


def fuzz(tmp_path: Path, *args: str) -> tuple[int, dict, str]:
    summary = tmp_path / "summary.json"
    run = subprocess.run([sys.executable, str(FUZZ), "--quiet", "--summary-json", str(summary), *args],
                         capture_output=True, text=True, timeout=HARNESS_TIMEOUT_S)
    assert summary.exists(), run.stderr[-3000:]
    return run.returncode, json.loads(summary.read_text()), run.stdout


def test_a_short_campaign_covers_every_category_and_finds_nothing(tmp_path):
    status, summary, _ = fuzz(tmp_path, "--cases", "500", "--chunk", "250", "--seed", "12")
    counts = summary["counts"]
    assert sum(sum(c.values()) for c in counts.values()) == 500
    for category, outcomes in counts.items():
        # Each category both runs through and is refused somewhere: the cases reach past
        # the argument checks and also probe them.
        assert outcomes.get("ok", 0) > 0 and outcomes.get("typed_error", 0) > 0, (category, outcomes)
    # Every built-in system is fuzzed, not only Tachyon 3.
    assert all(summary["systems"].get(name, 0) > 0 for name in cbfgen.systems()), summary["systems"]
    assert [(f["case"], f["outcome"], f["detail"][:300]) for f in summary["findings"]] == []
    assert status == 0


@pytest.mark.parametrize("kind", ["abort", "hang", "panic", "nonfinite"])
def test_each_kind_of_finding_is_attributed_to_its_case(tmp_path, kind):
    status, summary, stdout = fuzz(tmp_path, "--cases", "6", "--chunk", "6", "--seed", "3",
                                   "--case-timeout", "3", "--inject", f"{kind}:3")
    assert status == 1
    assert {"case": 3, "outcome": kind} in [{"case": f["case"], "outcome": f["outcome"]} for f in summary["findings"]]
    # The campaign went on after the case: all six were counted.
    assert sum(sum(c.values()) for c in summary["counts"].values()) == 6
    assert f"[{kind}] case 3" in stdout
