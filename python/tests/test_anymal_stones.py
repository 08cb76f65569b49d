"""Seed 004's stepping stones from Python: the field's bindings against its own geometry
(each stone's top where the table says, a point's misstep the distance to the nearest
square computed here), bad fields and controllers refused, and a short walk of the
proposed controller in MuJoCo that reaches the last stones with no misstep, judged on
MuJoCo's foot spheres."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("CBFGEN_REQUIRE_BINDINGS"):
    import cbfgen  # noqa: F401  (the package this module is part of)
else:
    pytest.importorskip("cbfgen", reason="build it with `scripts/cbf setup`")

from cbfgen import anymal  # noqa: E402


def square_distance(stones: np.ndarray, x: float, y: float) -> float:
    dx = np.maximum(np.abs(x - stones[:, 0]) - stones[:, 3], 0.0)
    dy = np.maximum(np.abs(y - stones[:, 1]) - stones[:, 3], 0.0)
    return float(np.min(np.hypot(dx, dy)))


def test_a_field_is_squares_where_its_table_says():
    field = anymal.SteppingStones(strides=5, seed=2)
    stones = field.stones
    assert stones.shape[1] == 4 and len(stones) >= 4 + 2 * 5
    assert np.all(stones[:, 3] == 0.07)
    assert np.all(np.abs(stones[:, 2]) <= 0.02 + 1e-12)
    assert field.speed == pytest.approx(0.337, abs=1e-3)  # d / 7T, d = 0.7069 m
    assert field.distance == pytest.approx(field.speed * 2 * 0.3 * 5)
    rng = np.random.default_rng(0)
    for x, y in rng.uniform([-0.6, -0.5], [2.2, 0.5], size=(500, 2)):
        assert field.misstep(x, y) == pytest.approx(square_distance(stones, x, y), abs=1e-12)
        nearest = np.argmin(np.hypot(np.maximum(np.abs(x - stones[:, 0]) - 0.07, 0),
                                     np.maximum(np.abs(y - stones[:, 1]) - 0.07, 0)))
        assert field.nearest_top(x, y) == stones[nearest, 2]
    # The same seed lays the same field; another seed another.
    assert np.array_equal(anymal.SteppingStones(strides=5, seed=2).stones, stones)
    assert not np.array_equal(anymal.SteppingStones(strides=5, seed=3).stones, stones)


def test_rows_lie_a_fixed_pitch_apart_and_their_displacements_default_to_centimetres():
    rows = anymal.SteppingStones(strides=6, seed=4, layout="rows", displacement=(0.0, 0.0, 0.0))
    stones = rows.stones
    for side in (stones[stones[:, 1] > 0], stones[stones[:, 1] < 0]):
        gaps = np.diff(np.sort(side[:, 0]))
        assert np.allclose(gaps, gaps[0], atol=1e-9) and gaps[0] == pytest.approx(0.24, abs=0.01)
    displaced = anymal.SteppingStones(strides=6, seed=4, layout="rows").stones
    shift = np.abs(displaced[4:, :3] - stones[4:, :3]).max(axis=0)
    assert np.all(shift <= [0.03 + 1e-12, 0.02 + 1e-12, 0.02 + 1e-12]) and shift[0] > 0.02


@pytest.mark.parametrize("bad", [dict(strides=0), dict(swings_between=4), dict(size=float("nan")),
                                 dict(displacement=(0.1, 0.0, 0.0)), dict(swing=-0.3), dict(layout="grid"),
                                 dict(layout="rows", pitch=0.1)])
def test_meaningless_fields_are_refused(bad):
    with pytest.raises((ValueError, cbfgen.CbfError)):
        anymal.SteppingStones(**bad)


def test_an_unknown_controller_is_refused_by_name():
    with pytest.raises(ValueError, match="CBF in QP & MPC"):
        anymal.StoneWalk(anymal.SteppingStones(strides=1), "CBF everywhere")


def test_an_unknown_foothold_barrier_is_refused_naming_both_sets():
    with pytest.raises(ValueError, match="region.*shrinking"):
        anymal.StoneWalk(anymal.SteppingStones(strides=1), barrier="grown")
    with pytest.raises(ValueError, match="region.*extent.*shrinking"):
        anymal.StoneWalk(anymal.SteppingStones(strides=1), whole_body_barrier="grown")
    with pytest.raises((ValueError, cbfgen.CbfError)):
        anymal.StoneWalk(anymal.SteppingStones(strides=1), mpc_stage=0.0)


def test_the_proposed_controller_walks_a_short_field_in_mujoco_without_a_misstep():
    pytest.importorskip("mujoco", reason="installed from python/requirements.txt")
    from cbfgen.physics.anymal import walk_stones

    field = anymal.SteppingStones(strides=3, seed=5)
    record = walk_stones(field, "CBF in QP & MPC").record
    assert record["fell"] is None and not record["body_contact"]
    landings = np.asarray(record["landings"])
    assert len(landings) >= 12 and landings.shape[1] == 11
    for time, foot, x, y, _z, misstep, height, px, py, _pz, planned_misstep in landings:
        # Judged here against the squares, not by the binding's misstep: where the foot
        # landed and where its plan put it.
        assert square_distance(field.stones, x, y) == 0.0, (time, foot, x, y)
        assert square_distance(field.stones, px, py) == planned_misstep == 0.0, (time, foot, px, py)
        assert misstep == 0.0
        # MuJoCo's soft contact lets a sphere sink a little into the stone it lands on.
        assert abs(height) <= 0.01, (time, foot, height)
    assert record["travelled_m"] == pytest.approx(field.distance, abs=0.05)
    # Eq. 24's barrier values: the region's, raised on swing feet (never lowered), most of
    # the swing time by a growth of up to 25 cm.
    barriers, shrinking = np.asarray(record["barriers"]), np.asarray(record["barriers_24"])
    assert shrinking.shape == (len(barriers), 4)
    raised = shrinking - barriers[:, 1:]
    assert np.all(raised >= 0.0) and np.all(raised <= 0.25 + 1e-12) and np.mean(raised > 0.0) > 0.3


def test_the_table_command_runs_a_chosen_controller_on_rows_and_refuses_bad_choices(tmp_path):
    pytest.importorskip("mujoco", reason="installed from python/requirements.txt")
    import json

    from cbfgen.physics import stepping_stones

    out = tmp_path / "stones"
    argv = ["--fields", "1", "--strides", "1", "--controllers", "3", "--layout", "rows", "--no-video",
            "--out", str(out)]
    assert stepping_stones.main(argv) == 0
    written = json.loads((out / "runs.json").read_text())
    assert written["layout"] == "rows" and list(written["runs"]) == ["CBF in QP & MPC"]
    (record,) = written["runs"]["CBF in QP & MPC"]
    landings = np.asarray(record["landings"])
    assert landings.shape[1] == 11 and record["steps"] == len(landings) >= 4
    table = (out / "table2.md").read_text()
    assert "in rows" in table and f"| missteps | {record['missteps']} (1) |" in table
    assert (out / "fig6_cbf_in_qp_and_mpc.png").exists() and not (out / "fig5_cbf_in_mpc.png").exists()
    for bad in ("4", "12", "0,,1", "x"):
        with pytest.raises(SystemExit):
            stepping_stones.main(["--controllers", bad, "--no-video", "--out", str(out)])
