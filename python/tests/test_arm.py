"""The 7-DoF arm (systems/panda/spec/panda.py) through the generic bindings: its spec's
families as the module reports them, and the example's closed loop (examples/arm_filter.py)
keeping every certified obstacle row non-negative, which it does not without the filter."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen
else:
    cbfgen = pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "arm_filter.py"


def _example():
    pytest.importorskip("matplotlib")
    spec = importlib.util.spec_from_file_location("arm_filter", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_arm_is_a_built_in_system_with_four_families_of_two_degrees():
    assert "panda" in cbfgen.systems()
    arm = cbfgen.System("panda")
    assert (arm.nx, arm.nu) == (14, 7)
    degrees = {f["name"]: f["relative_degree"] for f in arm.families}
    assert degrees == {"joint_limits": 2, "velocity_limits": 1, "obstacle": 2, "self_collision": 2}
    members = {f["name"]: f["members"] for f in arm.families}
    # One obstacle member per moving link box, one self-collision member per SRDF pair.
    assert len(members["obstacle"]) == 10 and len(members["self_collision"]) == 20


def test_the_filter_keeps_the_obstacle_certificates_and_the_pd_alone_does_not():
    example = _example()
    with_filter = example.run(2.0, filtered=True)
    without = example.run(2.0, filtered=False)
    assert with_filter["min_obstacle_h"].min() >= -1e-6
    assert without["min_obstacle_h"].min() < -0.05
