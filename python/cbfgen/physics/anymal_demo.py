"""``python -m cbfgen.physics.anymal_demo``: ANYmal C in MuJoCo under the whole-body
controller — standing, a trot at 0.3 m/s, and the foothold CBF on its own (a trot in
place whose reference asks the LF foot 10 cm past its 3 cm square, with and without the
CBF) — with a summary of each run, figures and a side-by-side GIF of the foothold runs."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from types import SimpleNamespace


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cbfgen.physics.anymal_demo", description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("out/anymal"), help="output folder; default out/anymal")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds of standing and trotting")
    parser.add_argument("--no-video", action="store_true", help="skip the GIF (needs no OpenGL then)")
    args = parser.parse_args(argv)

    if not args.no_video:
        # Chooses MuJoCo's OpenGL back end, so it comes before anything imports mujoco.
        from .render import FRAME_PERIOD, write_side_by_side_gif
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .anymal import STEPS_PER_CYCLE, TIMESTEP, run

    keep = 0 if args.no_video else int(round(FRAME_PERIOD / (TIMESTEP * STEPS_PER_CYCLE)))
    runs = {}
    for label, scenario, cbf, seconds in [("stand", "stand", True, args.seconds), ("trot", "trot", True, args.seconds),
                                          ("footholds_cbf", "footholds", True, 3.0),
                                          ("footholds_no_cbf", "footholds", False, 3.0)]:
        print(f"anymal: {label} ...", file=sys.stderr, flush=True)
        runs[label] = run(scenario, cbf=cbf, seconds=seconds, keep_every=keep)
        print(json.dumps(runs[label].summary(), indent=1))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "summary.json").write_text(json.dumps({k: r.summary() for k, r in runs.items()}, indent=1) + "\n")

    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    trot = runs["trot"]
    trunk, reference = np.array(trot.trunk), np.array(trot.trunk_reference)
    for ax, k, name in zip(axes, range(3), "xyz", strict=True):
        ax.plot(trot.t, reference[:, k], "k--", label="reference")
        ax.plot(trot.t, trunk[:, k], label="MuJoCo")
        ax.set_ylabel(f"trunk {name} [m]")
    axes[0].legend()
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("ANYmal C trotting at 0.3 m/s in MuJoCo under the whole-body controller")
    fig.tight_layout()
    fig.savefig(args.out / "trot_trunk.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4))
    for label, style in [("footholds_cbf", "-"), ("footholds_no_cbf", ":")]:
        r = runs[label]
        ax.plot(r.t, np.array(r.feet)[:, 0, 0], style, label=f"LF foot x, {'with' if r.cbf else 'without'} CBF")
    edge = runs["footholds_cbf"].squares[0, 1]
    ax.axhline(edge, color="r", lw=1, label="its square's front edge")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("x [m]")
    ax.legend()
    ax.set_title("The foothold CBF at priority 0: the reference asks the foot 10 cm forward")
    fig.tight_layout()
    fig.savefig(args.out / "footholds.png", dpi=120)
    plt.close(fig)

    if not args.no_video:
        from .anymal import Robot

        model = Robot().model
        columns = []
        for label, title in [("footholds_cbf", "with the foothold CBF"), ("footholds_no_cbf", "without"),
                             ("trot", "trot at 0.3 m/s")]:
            r = runs[label]
            columns.append((title, SimpleNamespace(model=model, qpos=r.qpos,
                                                   body_contact=r.body_contact[::keep])))
        write_side_by_side_gif(args.out / "anymal.gif", columns)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
