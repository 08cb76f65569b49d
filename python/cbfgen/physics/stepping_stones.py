"""``python -m cbfgen.physics.stepping_stones``: seed 004's stepping-stone experiment
(section V, Table II, Figs. 4-6) in MuJoCo. Each of the four controllers walks the same
seeded stone fields (:class:`cbfgen.anymal.SteppingStones`, under the gait or in rows away
from it); the command writes Table II summed over the fields beside the seed's figures,
every walk's record, the barrier figures of "CBF in MPC" and "CBF in QP & MPC" on the
first field (Figs. 5-6), and a GIF of the proposed controller's walk on it with two
stills (Fig. 4)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

SEED_TABLE = {
    "CBF-QP": {"steps": 28, "missteps": 5, "mean_misstep_mm": 1.4, "swing_time_s": 11.0,
               "violated_24_s": 2.4, "violated_25_s": 3.3},
    "CBF in MPC": {"steps": 140, "missteps": 6, "mean_misstep_mm": 2.5, "swing_time_s": 49.0,
                   "violated_24_s": 2.3, "violated_25_s": 5.4},
    "MPC baseline": {"steps": 140, "missteps": 5, "mean_misstep_mm": 4.3, "swing_time_s": 48.6,
                     "violated_24_s": 15.3, "violated_25_s": 15.6},
    "CBF in QP & MPC": {"steps": 140, "missteps": 1, "mean_misstep_mm": 1.2, "swing_time_s": 48.2,
                        "violated_24_s": 0.5, "violated_25_s": 0.8},
}
"""Seed 004's Table II (one field, its robot and simulator)."""

ROWS = [("steps", "steps", "{:d}"), ("missteps", "missteps", "{:d}"),
        ("mean_misstep_mm", "avg. misstep [mm]", "{:.1f}"), ("swing_time_s", "total swing time [s]", "{:.1f}"),
        ("violated_24_s", "time eq. 24 violated [s]", "{:.2f}"),
        ("violated_25_s", "time eq. 25 violated [s]", "{:.2f}"), ("falls", "fields where it fell", "{:d}"),
        ("planned_missteps", "missteps already in the plan", "{:d}"),
        ("mpc_failures", "MPC iterations without a plan", "{:d}")]
"""Table II's rows: the record's key, the label, the format."""


def table(runs: dict[str, list[dict]]) -> dict[str, dict[str, float]]:
    """Table II's columns from each controller's records (one per field): counts and
    times summed over the fields, the average misstep over all missteps, falls counted."""
    out = {}
    for controller, records in runs.items():
        landings = [np.asarray(r["landings"]).reshape(-1, 11) for r in records]
        missteps = [row[5] for rows in landings for row in rows if row[5] > 0.0]
        out[controller] = {
            "steps": int(sum(r["steps"] for r in records)),
            "missteps": len(missteps),
            "mean_misstep_mm": 1e3 * float(np.mean(missteps)) if missteps else 0.0,
            "swing_time_s": float(sum(r["swing_time_s"] for r in records)),
            "violated_24_s": float(sum(r["violated_24_s"] for r in records)),
            "violated_25_s": float(sum(r["violated_25_s"] for r in records)),
            "falls": int(sum(r["fell"] is not None for r in records)),
            "planned_missteps": int(sum(int(np.sum(rows[:, 10] > 0.0)) for rows in landings)),
            "mpc_failures": int(sum(r["mpc_failures"][0] for r in records)),
        }
    return out


def markdown(ours: dict[str, dict[str, float]], fields: int, layout: str = "gait") -> str:
    names = list(ours)
    where = "under the gait" if layout == "gait" else "in rows"
    lines = [f"| ({fields} fields {where}, MuJoCo) | " + " | ".join(names) + " |",
             "|---" * (len(names) + 1) + "|"]
    for key, label, form in ROWS:
        cells = []
        for name in names:
            cell = form.format(ours[name][key])
            if key in SEED_TABLE[name]:
                cell += f" ({SEED_TABLE[name][key]})"
            cells.append(cell)
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\nIn brackets: seed 004's Table II (one field).\n"


def barrier_figure(record: dict, title: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .. import anymal

    barriers = np.asarray(record["barriers"])
    shrinking = np.asarray(record["barriers_24"]).reshape(-1, 4)
    fig, axes = plt.subplots(4, 1, figsize=(8, 7), sharex=True)
    for foot, ax in enumerate(axes):
        h = np.where(np.isfinite(barriers[:, 1 + foot]), barriers[:, 1 + foot], np.nan)
        h24 = np.where(np.isfinite(shrinking[:, foot]), shrinking[:, foot], np.nan)
        ax.plot(barriers[:, 0], 1e3 * h, lw=0.8, color="0.6", label="on the landing region")
        ax.plot(barriers[:, 0], 1e3 * h24, lw=1, label="on eq. 24's shrinking set")
        ax.axhline(0.0, color="r", lw=0.8)
        ax.set_ylabel(f"{anymal.LEGS[foot]} h [mm]")
        ax.set_ylim(-200, 80)
    axes[0].legend(loc="lower right", fontsize=7)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"{title}: each foot's smallest barrier value\n"
                 "(swing: on where it lands, the set closing onto it at touchdown; stance: where it stands)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _indices(text: str) -> list[int]:
    """``--controllers``: indices into Table II's four controllers, e.g. ``0,3``."""
    from .. import anymal

    count = len(anymal.CONTROLLERS)
    try:
        indices = [int(k) for k in text.split(",")]
    except ValueError:
        indices = []
    if not indices or any(k not in range(count) for k in indices):
        raise argparse.ArgumentTypeError(f"{text!r}: indices 0-{count - 1} separated by commas")
    return indices


def main(argv: list[str] | None = None) -> int:
    from .. import anymal

    parser = argparse.ArgumentParser(prog="python -m cbfgen.physics.stepping_stones", description=__doc__)
    parser.add_argument("--fields", type=int, default=5, help="stone fields (seeds 0..N-1); default 5")
    parser.add_argument("--strides", type=int, default=8, help="strides per field; default 8")
    parser.add_argument("--out", type=Path, default=Path("out/stepping_stones"), help="default out/stepping_stones")
    parser.add_argument("--no-video", action="store_true", help="skip the GIF (needs no OpenGL then)")
    parser.add_argument("--threaded", action="store_true",
                        help="the MPC in its own thread, the walks in real time (default: inline, deterministic)")
    parser.add_argument("--gamma", type=float, default=None,
                        help="eq. 25's rate [1/s]; default 30 (the shrinking set needs at least 20)")
    parser.add_argument("--barrier", choices=anymal.FOOTHOLD_BARRIERS, default=None,
                        help="the set eq. 25's CBF (the MPC's) keeps a swing foot in: eq. 24's set shrinking onto its "
                             "landing region (default) or the region itself")
    parser.add_argument("--whole-body-barrier", choices=anymal.WHOLE_BODY_BARRIERS, default=None,
                        help="the set of eq. 26's CBF (the whole-body QP's): eq. 24's set as it stands each cycle "
                             "(default), the region, or eq. 24's set with its shrinking in the rows")
    parser.add_argument("--layout", choices=("gait", "rows"), default="gait",
                        help="stones under the trot's footholds (default) or in rows away from them")
    parser.add_argument("--pitch", type=float, default=0.24, help="the rows' stone spacing [m]; default 0.24")
    parser.add_argument("--size", type=float, default=0.14, help="the stones' side [m]; default 0.14")
    parser.add_argument("--mpc-stage", type=float, default=None,
                        help="the MPC's stage length [s], its horizon kept at 1 s; default 0.04")
    parser.add_argument("--controllers", type=_indices, default=None,
                        help="comma-separated indices into Table II's order (0-3); default all four")
    args = parser.parse_args(argv)
    if args.fields < 1 or args.strides < 1:
        parser.error("--fields and --strides must be at least 1")

    if not args.no_video:
        # Chooses MuJoCo's OpenGL back end, so it comes before anything imports mujoco.
        from .render import FRAME_PERIOD, write_side_by_side_gif
    from .anymal import STEPS_PER_CYCLE, TIMESTEP, walk_stones

    keep = 0 if args.no_video else int(round(FRAME_PERIOD / (TIMESTEP * STEPS_PER_CYCLE)))
    args.out.mkdir(parents=True, exist_ok=True)
    chosen = anymal.CONTROLLERS if args.controllers is None else [anymal.CONTROLLERS[k] for k in args.controllers]
    runs: dict[str, list[dict]] = {name: [] for name in chosen}
    video = None
    for name in chosen:
        for seed in range(args.fields):
            stones = anymal.SteppingStones(strides=args.strides, seed=seed, layout=args.layout, pitch=args.pitch,
                                           size=args.size)
            proposed_first = name == anymal.CONTROLLERS[-1] and seed == 0
            run = walk_stones(stones, name, keep_every=keep if proposed_first else 0, threaded=args.threaded,
                              gamma=args.gamma, barrier=args.barrier, mpc_stage=args.mpc_stage,
                              whole_body_barrier=args.whole_body_barrier)
            record = run.record
            print(f"stepping stones: {name}, field {seed}: {record['steps']} steps, {record['missteps']} missteps, "
                  f"fell {record['fell']}", file=sys.stderr, flush=True)
            runs[name].append(record)
            if proposed_first and not args.no_video:
                video = run
    ours = table(runs)
    (args.out / "table2.md").write_text(markdown(ours, args.fields, args.layout))
    serial = {name: [{k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()}
                     for r in records] for name, records in runs.items()}
    (args.out / "runs.json").write_text(json.dumps({"fields": args.fields, "strides": args.strides,
                                                    "layout": args.layout, "pitch": args.pitch,
                                                    "table": ours, "seed_table": SEED_TABLE, "runs": serial}) + "\n")
    figures = [("CBF in MPC", 5, "fig5_cbf_in_mpc.png"), ("CBF in QP & MPC", 6, "fig6_cbf_in_qp_and_mpc.png")]
    for name, fig, file in figures:
        if name in runs:
            barrier_figure(runs[name][0], f"{name} (Fig. {fig})", args.out / file)
    print(markdown(ours, args.fields, args.layout))
    if video is not None:
        write_side_by_side_gif(args.out / "proposed.gif",
                               [("CBF in QP & MPC", SimpleNamespace(model=video.model, qpos=video.qpos,
                                                                    body_contact=video.body_contact))],
                               stills=args.out / "fig4_snapshot.png", still_times=(1.5, 3.0))
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
