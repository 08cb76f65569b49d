"""``python -m cbfgen.physics``: the hardware stairs in MuJoCo, with and without the body
CBF; summaries, Figs. 7–10 of the physical run and a side-by-side GIF of the climbs.
``--perception``: the same on perceived terrain from a drifting state estimate, as the
paper's robot climbed them."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cbfgen.physics", description=__doc__)
    parser.add_argument(
        "--scenario", default="stairs", help="course (cbfgen.physics.PHYSICAL_SCENARIOS); default stairs"
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output folder; default out/mujoco (out/mujoco_perceived with --perception)",
    )
    parser.add_argument("--max-time", type=float, default=None, help="simulated seconds at most per run")
    parser.add_argument("--no-video", action="store_true", help="skip the GIF (needs no OpenGL then)")
    parser.add_argument(
        "--perception",
        action="store_true",
        help="the paper's hardware run: the gait and filter see only what the LiDAR perceives, "
        "and act on a state estimate with drift and noise (cbfgen.physics.PoseEstimate)",
    )
    parser.add_argument(
        "--origin",
        choices=["rolling", "jump_at_exchange"],
        default="rolling",
        help="how the ground-moving origin moves: rolling (default) or the paper's jump at each support exchange",
    )
    args = parser.parse_args(argv)
    if args.out is None:
        args.out = Path("out/mujoco_perceived" if args.perception else "out/mujoco")

    if not args.no_video:
        # Chooses MuJoCo's OpenGL back end, so it comes before anything imports mujoco.
        from .render import FrameRecorder, write_side_by_side_gif
    from .figures import write_figures, write_turn_figure
    from .loop import PoseEstimate, check_physical_scenario, run
    from .model import ASSUMED

    try:
        check_physical_scenario(args.scenario)
    except ValueError as refused:
        parser.error(str(refused))
    args.out.mkdir(parents=True, exist_ok=True)
    runs, recorders = {}, {}
    for body_cbf in (True, False):
        label = "with body CBF" if body_cbf else "without body CBF"
        recorder = None if args.no_video else FrameRecorder()
        print(f"physics: {args.scenario} {label} ...", file=sys.stderr, flush=True)
        estimate = PoseEstimate() if args.perception else None
        runs[body_cbf] = run(
            args.scenario, body_cbf, args.max_time, on_cycle=recorder, perception=estimate, origin=args.origin
        )
        recorders[body_cbf] = recorder
        summary = runs[body_cbf].summary()
        print(json.dumps(summary, indent=1))
    report = {
        "assumed": ASSUMED,
        "pose_estimate": dataclasses.asdict(PoseEstimate()) if args.perception else None,
        "origin": args.origin,
        "with_body_cbf": runs[True].summary(),
        "without_body_cbf": runs[False].summary(),
    }
    (args.out / f"{args.scenario}_physics.json").write_text(json.dumps(report, indent=1) + "\n")
    written = write_figures(runs[True], runs[False], args.out) + write_turn_figure(runs[True], args.out)
    if not args.no_video:
        gif, stills = args.out / f"{args.scenario}_physics.gif", args.out / f"{args.scenario}_physics_stills.png"
        end = min(r.t[-1] for r in runs.values())
        frames = write_side_by_side_gif(
            gif,
            [("with body CBF", recorders[True]), ("without body CBF", recorders[False])],
            stills=stills,
            still_times=[end * f for f in (0.25, 0.7, 0.85)],
        )
        written += [gif, stills]
        print(f"physics: {gif} has {frames} frames", file=sys.stderr)
    print("wrote " + ", ".join(str(p) for p in [args.out / f"{args.scenario}_physics.json", *written]), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
