"""The 7-DoF arm's safety filter from Python, through the generic bindings, plotted.

A joint-space PD sweeps the base joint of the `panda` system (systems/panda/spec/panda.py)
across a box standing 0.5 m in front of it: the forearm and wrist would pass through
the box. Each 1 ms cycle `cbfgen.EcbfFilter` corrects the PD's joint accelerations; the
loop integrates q'' = u exactly. It runs with the filter and without, and plots the
smallest obstacle barrier h (its rows are certified: h >= 0 proves the link box and the
obstacle do not overlap) and the base joint's angle.

    scripts/cbf python examples/arm_filter.py [--seconds 6] [--out FILE.png]

The same scenario, with exact separations, self-collision and joint limits, is
`cbfgen arm` (systems/panda/src/).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display needed
import cbfgen  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

DT = 1e-3
START = np.array([0.7, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785])
TARGET = np.array([-0.7, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785])
KP, KD, CRUISE = 16.0, 8.0, 0.8  # the PD approaches far targets at 0.8 rad/s
OBSTACLES = {  # name: (centre, half extents), axis-aligned, base frame [m]
    "table": ([0.3, 0.0, -0.05], [0.7, 0.8, 0.05]),
    "box": ([0.5, 0.0, 0.25], [0.08, 0.08, 0.25]),
}


def environment(arm: cbfgen.System) -> cbfgen.Params:
    """Every link box (a member of the obstacle family) checked against every obstacle."""
    links = next(f for f in arm.families if f["name"] == "obstacle")["members"]
    params = arm.params({"obstacle": [len(OBSTACLES)] * len(links)})
    for center, half in OBSTACLES.values():
        for link in links:
            params.push("obstacle", {"center": center, "rotation": np.eye(3), "half": half}, member=link)
    return params


def run(seconds: float, filtered: bool) -> dict[str, np.ndarray]:
    arm = cbfgen.System("panda")
    params = environment(arm)
    safety = arm.filter(params.capacity)
    lo, hi = arm.input_min, arm.input_max
    x = np.concatenate([START, np.zeros(7)])
    obstacle_rows = [i for i, place in enumerate(arm.rows(x, params).layout) if place[0] == "obstacle"]
    log: dict[str, list[float]] = {"t": [], "q1": [], "min_obstacle_h": []}
    for k in range(int(seconds / DT)):
        q, qd = x[:7], x[7:]
        reach = CRUISE * KD / KP
        u_ref = KP * np.clip(TARGET - q, -reach, reach) - KD * qd
        u = safety.update(x, u_ref, params).u if filtered else np.clip(u_ref, lo, hi)
        rows = arm.rows(x, params)
        h = rows.lie[obstacle_rows, 0]
        log["t"].append(k * DT)
        log["q1"].append(q[0])
        log["min_obstacle_h"].append(min(h))
        x = np.concatenate([q + qd * DT + 0.5 * u * DT**2, qd + u * DT])
    return {k: np.asarray(v) for k, v in log.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated time [s]")
    parser.add_argument("--out", type=Path, default=Path("out/arm_filter.png"))
    args = parser.parse_args()

    runs = {filtered: run(args.seconds, filtered) for filtered in (True, False)}
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    for filtered, style in ((True, "-"), (False, "--")):
        r = runs[filtered]
        label = "with the filter" if filtered else "without"
        top.plot(r["t"], r["min_obstacle_h"], style, label=label)
        bottom.plot(r["t"], r["q1"], style, label=label)
        print(f"{label}: smallest obstacle h {r['min_obstacle_h'].min():+.4f} m")
    top.axhline(0.0, color="black", linewidth=0.8)
    top.set_ylabel("smallest obstacle h [m]\n(< 0: no proof of clearance)")
    bottom.set_ylabel("base joint q1 [rad]")
    bottom.set_xlabel("t [s]")
    top.legend()
    top.set_title("panda: PD sweep across a box, ECBF filter via the generic bindings")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    if runs[True]["min_obstacle_h"].min() < -1e-6:
        raise SystemExit("the filtered arm lost its clearance certificate")


if __name__ == "__main__":
    main()
