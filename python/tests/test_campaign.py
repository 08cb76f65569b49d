"""cbfgen.campaign: campaigns on engines (this process, an Executor, Ray) give the same
rows; a falsifier finds a planted weakness sooner than uniform sampling; the importance
sampling estimate covers a failure probability known in closed form."""

from __future__ import annotations

import doctest
import importlib.util
import math
import os
from concurrent.futures import ThreadPoolExecutor

import cbfgen
import cbfgen.campaign as campaign
import numpy as np
import pytest
from cbfgen import tachyon3 as t3
from cbfgen.campaign import ArmObstacles, Measure, Parameter, Scenario, TachyonStairs, falsify, run_campaign

# One or two low steps keep Tachyon 3's episodes short.
SHORT = {"rise": [0.05, 0.08], "steps": [1, 2], "start_gap": [0.1, 0.2], "speed": [0.3, 0.4]}


def outcome(rows, scenario):
    """Rows without the columns that depend on the machine and the moment."""
    return [{k: v for k, v in r.items() if k not in scenario.timing_columns} for r in rows]


def test_a_two_worker_ray_run_gives_the_single_process_rows():
    ray = pytest.importorskip("ray")
    stairs = TachyonStairs(ranges=SHORT)
    alone = run_campaign(stairs, 6, seed=9, first_id=3)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        seen = []
        on_ray = run_campaign(stairs, 6, seed=9, first_id=3, engine="ray", progress=lambda d, n: seen.append((d, n)))
    finally:
        ray.shutdown()
    assert on_ray.shards == 6 and on_ray.engine == "Ray (ray)"  # four shards per CPU, at most one per episode
    assert [r["id"] for r in on_ray.rows] == list(range(3, 9))
    assert outcome(on_ray.rows, stairs) == outcome(alone.rows, stairs)
    assert [d for d, _ in seen] == [1, 2, 3, 4, 5, 6] and {n for _, n in seen} == {6}
    # The rows are Rust's own campaign of the same seed, to the bit.
    direct = campaign.parse_rows(t3.campaign(episodes=6, seed=9, first_id=3, ranges=SHORT)["csv"])
    assert outcome(alone.rows, stairs) == outcome(direct, stairs)


def test_executor_shards_write_the_files_of_one_run(tmp_path):
    stairs = TachyonStairs(ranges=SHORT)
    with ThreadPoolExecutor(2) as pool:
        sharded = run_campaign(stairs, 5, seed=4, engine=pool, shards=3)
    written = sharded.write(tmp_path / "sharded")
    whole = t3.campaign(episodes=5, seed=4, ranges=SHORT)
    keep = [i for i, c in enumerate(whole["csv"].splitlines()[0].split(",")) if c not in stairs.timing_columns]

    def columns(text):
        return [[line.split(",")[i] for i in keep] for line in text.splitlines()]

    assert columns((tmp_path / "sharded" / "episodes.csv").read_text()) == columns(whole["csv"])
    def untimed(report):
        return [line for line in report.splitlines() if not any(t in line for t in ("CPU", "wall", "µs"))]

    assert untimed((tmp_path / "sharded" / "report.txt").read_text()) == untimed(whole["report"])
    assert {p.name for p in written} >= {"episodes.csv", "report.txt", "campaign_outcome_map.png"}
    # Each row says how to run it again, and that command's course is the row's.
    replay = stairs.replay(sharded.rows[0])
    assert replay.startswith("cbfgen simulate --episode 0 --seed 4 --rise ")
    rise = sharded.rows[0]["rise"]
    assert f"--rise {rise!r},{rise!r}" in replay


class NumpyMeasures(Scenario):
    """Measures as a scenario computed with NumPy returns them: NumPy scalars."""

    name = "numpy measures"
    parameters = {"a": Parameter(-1.0, 1.0), "n": Parameter(0, 9, integer=True)}
    measures = (Measure("low", fails_below=-0.5), Measure("count", worse="higher", fails_above=5))

    def episode(self, params, seed, episode_id):
        return {"low": np.float64(params["a"]) / 3, "single": np.float32(0.25), "count": np.int64(params["n"]),
                "flag": np.bool_(params["a"] > 0), "none": None, "far": np.float64(np.inf)}


def test_numbers_of_any_numeric_type_are_written_as_numbers(tmp_path):
    done = run_campaign(NumpyMeasures(), 4, seed=1)
    done.write(tmp_path)
    import csv

    with open(tmp_path / "episodes.csv") as f:
        written = list(csv.DictReader(f))
    for row, record in zip(done.rows, written, strict=True):
        assert float(record["low"]) == float(row["low"])  # full precision, read back exactly
        assert record["single"] == "0.25" and int(record["count"]) == int(row["count"])
        assert record["flag"] in ("True", "False") and record["none"] == "" and record["far"] == ""
    # And they are measured: a NumPy integer is a value, not a missing one.
    count = NumpyMeasures.measures[1]
    assert count.badness(np.int64(7)) == -7.0 and count.failed(np.int64(7))


def example(name):
    """A class of examples/campaign_floor.py, the user's scenario the docs run."""
    path = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "campaign_floor.py")
    spec = importlib.util.spec_from_file_location("campaign_floor", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, name)


PlantedFloor = example("LoosenedFloor")


def test_the_falsifier_finds_a_planted_weakness_sooner_than_uniform_sampling():
    budget = 200
    found, uniform = [], []
    for seed in range(3):
        result = falsify(PlantedFloor(), budget=budget, seed=seed)
        found.append(result.first_failure)
        # The worst episode it reports went through the floor, and replays as reported.
        worst = result.worst(1)[0]
        assert worst["lowest"] < -1e-3
        params = {k: worst[k] for k in PlantedFloor.parameters}
        assert PlantedFloor().episode(params, worst["seed"], worst["id"])["lowest"] == worst["lowest"]
        assert worst["speed"] < -1.6 and worst["push"] > 8.0, worst  # in the planted corner
        fails = run_campaign(PlantedFloor(), budget, seed=seed).failures()
        uniform.append(fails[0] + 1 if fails else None)
    # Measured: the search's first failure came at episodes 61, 37 and 58 of 200;
    # uniform sampling found none in 200 at any of the three seeds.
    assert all(f is not None and f <= budget // 2 for f in found), found
    assert all(u is None or u > f for u, f in zip(uniform, found, strict=True)), (found, uniform)


class KnownCorner(Scenario):
    """A failure region known in closed form: a · b > 0.95 for a, b, c uniform on [0, 1]
    (c has no effect): P = 1 − c + c ln c at c = 0.95, 1.27e-3."""

    name = "known corner"
    parameters = {"a": Parameter(0.0, 1.0), "b": Parameter(0.0, 1.0), "c": Parameter(0.0, 1.0)}
    measures = (Measure("margin", fails_below=0.0),)

    def episode(self, params, seed, episode_id):
        return {"margin": 0.95 - params["a"] * params["b"]}


class KnownSlab(Scenario):
    """A broad failure region: a > 0.91 among five parameters, P = 0.09 (as broad as
    Tachyon 3's relaxed rows, 8.7 % of its random staircases)."""

    name = "known slab"
    parameters = {k: Parameter(0.0, 1.0) for k in "abcde"}
    measures = (Measure("margin", fails_below=0.0),)

    def episode(self, params, seed, episode_id):
        return {"margin": 0.91 - params["a"]}


@pytest.mark.parametrize(("scenario", "truth"), [(KnownCorner, 1.0 - 0.95 + 0.95 * math.log(0.95)), (KnownSlab, 0.09)])
def test_the_importance_sampling_interval_covers_a_probability_known_in_closed_form(scenario, truth):
    results = [falsify(scenario(), budget=200, seed=seed) for seed in range(20)]
    covered = sum(r.interval[0] <= truth <= r.interval[1] for r in results)
    estimates = np.array([r.probability for r in results])
    # Measured: the corner's interval holds it at 20 of 20 seeds, the slab's at 18.
    assert covered >= 17, [(r.probability, r.interval) for r in results]
    assert abs(estimates.mean() / truth - 1.0) < 0.2, estimates
    # The whole cube's share bounds every weight by 1 / 0.2.
    assert all(len(r.weights) == 100 and np.all(r.weights <= 5.0 + 1e-9) for r in results)


def test_the_module_example_runs():
    failures, _ = doctest.testmod(campaign, optionflags=doctest.ELLIPSIS)
    assert failures == 0


def test_shards_are_the_command_lines_blocks():
    # As cbfgen campaign --shard I/N cuts them (CampaignSettings::shard), by hand.
    assert campaign.shard_blocks(0, 3, 2) == [(0, 1), (1, 2)]
    assert campaign.shard_blocks(40, 7, 3) == [(40, 2), (42, 2), (44, 3)]
    blocks = campaign.shard_blocks(5, 1000, 7)
    assert sum(n for _, n in blocks) == 1000 and blocks[0][0] == 5
    assert all(a + n == b for (a, n), (b, _) in zip(blocks, blocks[1:], strict=False))


def test_draws_are_uniform_deterministic_and_whole_where_asked():
    scenario = TachyonStairs()
    draws = [KnownCorner().draw(7, i) for i in range(4000)]
    assert draws[:3] == [KnownCorner().draw(7, i) for i in range(3)]
    a = np.array([d["a"] for d in draws])
    assert 0.0 <= a.min() and a.max() <= 1.0 and abs(a.mean() - 0.5) < 0.02
    steps = Parameter(1, 6, integer=True)
    counts = np.bincount([steps.value(u) for u in np.random.default_rng(1).random(60_000)], minlength=7)[1:]
    assert np.all(np.abs(counts / 60_000 - 1 / 6) < 0.01), counts
    assert steps.value(0.0) == 1 and steps.value(1.0) == 6
    assert scenario.parameters["steps"] == Parameter(1, 6, integer=True)


def test_bad_settings_are_refused_with_a_message():
    with pytest.raises(ValueError, match="finite lo <= hi"):
        Parameter(1.0, 0.0)
    with pytest.raises(ValueError, match="whole bounds"):
        Parameter(0.5, 3, integer=True)
    with pytest.raises(ValueError, match="needs a finite fails_below"):
        Measure("x")
    with pytest.raises(ValueError, match="'lower' or 'higher'"):
        Measure("x", worse="up", fails_below=0.0)
    with pytest.raises(ValueError, match="episodes must be an integer >= 1"):
        run_campaign(KnownCorner(), 0)
    with pytest.raises(ValueError, match="shards must be from 1 to the 3 episodes"):
        run_campaign(KnownCorner(), 3, shards=4)
    with pytest.raises(TypeError, match="concurrent.futures.Executor"):
        run_campaign(KnownCorner(), 3, engine=os.cpu_count())
    with pytest.raises(ValueError, match="no measure 'depth'; known: margin"):
        falsify(KnownCorner(), "depth")
    with pytest.raises(ValueError, match="budget must be an integer >= 4"):
        falsify(KnownCorner(), budget=2)
    with pytest.raises(ValueError, match="no course range 'height'"):
        TachyonStairs(ranges={"height": [0.1, 0.2]})
    with pytest.raises(cbfgen.CbfError, match="rise"):
        TachyonStairs(ranges={"rise": [0.1, 0.5]})


def test_the_arm_among_obstacles_is_a_scenario_like_the_stairs():
    arm = ArmObstacles(obstacles=(5, 10), duration=2.0)
    result = run_campaign(arm, 2, seed=3)
    for row in result.rows:
        assert 5 <= row["obstacles"] <= 10 and isinstance(row["obstacles"], int)
        assert row["cycles"] == 2000 and row["fallback_cycles"] == 0
        assert 0.0 < row["median_cpu_us"] <= row["max_cpu_us"]  # the filter's own CPU time, measured
        # The filter holds the arm's spheres off the obstacles and the table (to rounding).
        assert row["min_obstacle_clearance"] > -1e-3 and row["min_table_clearance"] > -1e-3
        # The episode's layout is its own, from (seed, id): the same call gives the same run.
        again = cbfgen._native.arm_episode(
            obstacles=row["obstacles"], seed=row["layout_seed"], duration=2.0, cruise_speed=row["cruise_speed"]
        )
        assert again["min_obstacle_clearance"] == row["min_obstacle_clearance"]
    assert result.rows[0]["layout_seed"] != result.rows[1]["layout_seed"]
    # Without the filter the same sweep hits an obstacle or the table: the measure can fail.
    unfiltered = run_campaign(ArmObstacles(obstacles=(25, 25), duration=4.0, filter=False), 1, seed=3)
    assert unfiltered.failures("min_obstacle_clearance") + unfiltered.failures("min_table_clearance")
    with pytest.raises(ValueError, match="obstacles must be"):
        ArmObstacles(obstacles=(5, 1000))


def test_the_command_runs_a_users_scenario_file_on_a_process_pool(tmp_path):
    import subprocess
    import sys

    example = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "campaign_floor.py")
    command = [sys.executable, "-m", "cbfgen.campaign", "run", "--scenario", f"{example}:Floor", "--episodes", "6"]
    done = subprocess.run(
        [*command, "--engine", "processes", "--workers", "2", "--out", str(tmp_path / "pool")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    alone = subprocess.run([*command, "--out", str(tmp_path / "alone")], capture_output=True, text=True, check=False)
    assert alone.returncode == 0, alone.stderr
    assert "6 episodes in" in done.stdout and "ProcessPoolExecutor, 6 shards" in done.stdout
    # The same rows whatever ran them; the floor held in every episode.
    pool, single = ((tmp_path / d / "episodes.csv").read_text() for d in ("pool", "alone"))
    assert pool == single and len(pool.splitlines()) == 7
    assert "| lowest < -0.001 (failed) | 0 |" in (tmp_path / "pool" / "report.txt").read_text()
    bad = subprocess.run(
        [sys.executable, "-m", "cbfgen.campaign", "run", "--scenario", "nowhere"], capture_output=True, text=True
    )
    assert bad.returncode != 0 and "unknown scenario 'nowhere'" in bad.stderr
    refused = subprocess.run(
        [*command, "--out", str(tmp_path / "x"), "--seed", "-1"], capture_output=True, text=True, check=False
    )
    assert refused.returncode == 2 and refused.stderr.strip() == "error: seed must be an integer >= 0, got -1"


def test_perceived_stairs_are_the_same_scenario_on_perceived_terrain():
    one_step = {**SHORT, "steps": [1, 1]}
    perceived = TachyonStairs(ranges=one_step, perception=True)
    rows = run_campaign(perceived, 1, seed=2).rows
    direct = campaign.parse_rows(t3.campaign(episodes=1, seed=2, ranges=one_step, perception=True)["csv"])
    assert outcome(rows, perceived) == outcome(direct, perceived)
    true_terrain = run_campaign(TachyonStairs(ranges=one_step), 1, seed=2).rows
    # The same course, climbed on what the LiDAR saw: its clearances are not the true run's.
    assert rows[0]["rise"] == true_terrain[0]["rise"]
    assert rows[0]["min_body_clearance"] != true_terrain[0]["min_body_clearance"]
    assert perceived.replay(rows[0]).endswith(" --perception")
