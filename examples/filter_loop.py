"""Run the ECBF safety filter in a Python control loop and plot the body height.

The robot rolls at a 16.5 cm step under a naive gait (cbfgen.tachyon3.Course) that keeps the
body low and knows nothing about the body's size. Each 1 ms cycle the filter corrects
the gait's input; the loop integrates x' = f(x) + g(x) u with explicit Euler. It runs
twice: with every constraint, and with the body-edge SSAT rows switched off, which lets
the body strike the step's nosing.

    scripts/cbf python examples/filter_loop.py [--scenario step|stairs|turn|...] [--out FILE.png]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cbfgen import tachyon3 as t3  # noqa: E402


def run(scenario: str, body_cbf: bool, max_time: float) -> dict:
    course = t3.Course(scenario)
    # Without the body CBF its rows never activate: h is never below -inf.
    activation = None if body_cbf else {"body_edge": float("-inf")}
    safety = t3.ecbf_filter(activation=activation)
    x = course.initial_state()
    log = {k: [] for k in ("t", "body_z", "nominal_z", "clearance", "update_us")}
    done_at = None
    for k in range(int(max_time / t3.DT)):
        t = k * t3.DT
        x, _jump = course.exchange_origin(t, x)  # the origin onto a turning swing's drive axle
        u_ref = course.plan(t, x)
        out = safety.update(x, u_ref, course.environment)
        body_center, _, _ = t3.world_kinematics(x)
        log["t"].append(t)
        log["body_z"].append(body_center[2])
        log["nominal_z"].append(course.nominal_body_height)
        log["clearance"].append(course.clearance(x)[0])
        log["update_us"].append(out.eval_time_us + out.solve_time_us)
        if done_at is None and course.finished(x):
            done_at = t
        if done_at is not None and t - done_at > 1.0:
            break
        x = x + t3.DT * t3.SYSTEM.xdot(x, out.u)
    return {k: np.asarray(v) for k, v in log.items()} | {"finished": done_at is not None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", choices=t3.SCENARIOS, default="step")
    parser.add_argument("--max-time", type=float, default=25.0, help="give up after this long [s]")
    parser.add_argument("--out", type=Path, default=Path("out/filter_loop.png"))
    args = parser.parse_args()

    runs = {}
    for body_cbf in (True, False):
        start = time.perf_counter()
        r = runs[body_cbf] = run(args.scenario, body_cbf, args.max_time)
        print(f"body CBF {'on ' if body_cbf else 'off'}: {len(r['t'])} cycles in {time.perf_counter() - start:.1f} s, "
              f"finished={r['finished']}, min body clearance {1e3 * r['clearance'].min():+.1f} mm, "
              f"filter update median {np.median(r['update_us']):.0f} us")

    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(9, 6), constrained_layout=True)
    for body_cbf, colour in ((True, "tab:blue"), (False, "tab:red")):
        r = runs[body_cbf]
        label = "with body SSAT CBF" if body_cbf else "without"
        top.plot(r["t"], r["body_z"], color=colour, label=label)
        bottom.plot(r["t"], 1e3 * r["clearance"], color=colour, label=label)
    top.plot(runs[True]["t"], runs[True]["nominal_z"], "k--", lw=1, label="gait's nominal")
    top.set_ylabel("body centre height [m]")
    top.legend()
    bottom.axhline(0.0, color="k", lw=0.8)
    bottom.set_ylabel("body clearance to the steps [mm]\n(exact SAT; < 0 = collision)")
    bottom.set_xlabel("time [s]")
    bottom.legend()
    top.set_title(f"cbfgen ECBF filter in a Python loop: {args.scenario}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
