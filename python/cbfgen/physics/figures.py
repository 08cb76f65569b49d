"""The paper's Figs. 7–10 from physical runs, the tracking error, and a turn's yaw and
path, as PNG and SVG."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .. import tachyon3 as t3  # noqa: E402
from .loop import PhysicalRun  # noqa: E402


def _save(fig, out: Path, stem: str) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"{stem}.png", out / f"{stem}.svg"]
    for p in paths:
        fig.savefig(p, dpi=120)
    plt.close(fig)
    return paths


def write_figures(with_cbf: PhysicalRun, without_cbf: PhysicalRun | None, out: Path) -> list[Path]:
    """Figs. 7–10 of the physical run with the body CBF (Fig. 7 also without it) and its
    tracking error; returns the files written."""
    a = with_cbf.arrays()
    written: list[Path] = []
    world_z = a["x"][:, 2] + a["x"][:, 7]

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(a["t"], world_z, label="with body CBF (MuJoCo)")
    if a["body_contact"].any():
        touching = a["body_contact"]
        ax.scatter(a["t"][touching], world_z[touching], s=2, c="purple", label="body touches, with body CBF")
    if without_cbf is not None:
        b = without_cbf.arrays()
        ax.plot(b["t"], b["x"][:, 2] + b["x"][:, 7], label="without body CBF (MuJoCo)")
        touching = b["body_contact"]
        if touching.any():
            height = b["x"][:, 2] + b["x"][:, 7]
            ax.scatter(b["t"][touching], height[touching], s=2, c="red", label="body touches, without body CBF")
    ax.plot(a["t"], with_cbf.nominal_body_height, "k--", lw=0.8, label="gait's nominal")
    ax.set(title="Body height, physical robot (Fig. 7)", xlabel="time [s]", ylabel="body centre height [m]")
    ax.legend(fontsize=8)
    written += _save(fig, out, "mujoco_fig7_body_height")

    fig, ax = plt.subplots(figsize=(8, 4))
    families = sorted({f for row in with_cbf.min_h for f in row})
    for family in families:
        ax.plot(a["t"], [row.get(family, np.nan) for row in with_cbf.min_h], label=family, lw=0.8)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(title="Minimum h per family, physical robot (Fig. 8)", xlabel="time [s]", ylabel="h", ylim=(-0.05, 0.6))
    ax.legend(fontsize=7, ncol=3)
    written += _save(fig, out, "mujoco_fig8_min_h")

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(a["t"], a["computed_rows"], lw=0.6, label="computed (filled instances)")
    ax.plot(a["t"], a["computed_rows"] - a["culled_rows"], lw=0.6, label="evaluated in full (less the culled)")
    ax.plot(a["t"], a["active_rows"], lw=0.6, label="applied (in the QP)")
    ax.set(title="CBF rows, physical robot (Fig. 9)", xlabel="time [s]", ylabel="rows")
    ax.legend(fontsize=8)
    written += _save(fig, out, "mujoco_fig9_active_rows")

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(a["t"], a["update_us"], lw=0.4, label="wall (with any wait for the CPU)")
    ax.plot(a["t"], a["cpu_us"], lw=0.4, label="the thread's CPU time")
    ax.axhline(1000.0, color="k", lw=0.6, ls="--", label="the 1 ms period")
    ax.set(title="Filter time per cycle, physical robot (Fig. 10)", xlabel="time [s]", ylabel="rows + QP [µs]")
    ax.legend(fontsize=8)
    written += _save(fig, out, "mujoco_fig10_update_time")

    x, ref = a["x"], a["x_ref"]
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(a["t"], 1e3 * (x[:, 7] - ref[:, 7]), label="body height", lw=0.8)
    toe = np.hypot(x[:, 12::4] - ref[:, 12::4], x[:, 13::4] - ref[:, 13::4]).max(axis=1)
    ax.plot(a["t"], 1e3 * toe, label="worst toe position", lw=0.6)
    ax.set(title="Physical minus kinematic state", xlabel="time [s]", ylabel="error [mm]")
    ax.legend(fontsize=8)
    written += _save(fig, out, "mujoco_tracking_error")
    return written


def write_turn_figure(run: PhysicalRun, out: Path, stem: str = "mujoco_turn") -> list[Path]:
    """A run that turns: the reference's yaw and MuJoCo's body heading, and the yaw rate,
    with the intervals each tripod is lifted shaded (the yaw rate is zero whenever the
    six wheels are down), beside the body centre's path seen from above with the
    wheels' tracks. Returns the files written (none for a run that does not turn)."""
    a = run.arrays()
    t, ref = a["t"], a["x_ref"]
    if np.ptp(ref[:, 3]) < np.radians(1.0):
        return []
    heading = ref[:, 3] + a["heading"]
    fig, (yaw_ax, rate_ax, top) = plt.subplots(1, 3, figsize=(16, 5), gridspec_kw={"width_ratios": [1.2, 1.2, 1.0]})
    turning = np.abs(ref[:, 5]) > 1e-3
    span = (t[turning].min() - 1.5, t[turning].max() + 1.5)
    window = (t >= span[0]) & (t <= span[1])
    colours = {0: "tab:orange", 1: "tab:green"}
    for ax in (yaw_ax, rate_ax):
        for tripod, colour in colours.items():
            lifted = (a["swinging"] == tripod) & window
            ax.fill_between(t, 0, 1, where=lifted, color=colour, alpha=0.15, transform=ax.get_xaxis_transform(), lw=0)
        ax.set_xlim(*span)
    yaw_ax.plot(t[window], np.degrees(ref[window, 3]), "k--", lw=0.8, label="reference (cubic per swing)")
    yaw_ax.plot(t[window], np.degrees(heading[window]), lw=1.0, label="MuJoCo's body")
    yaw_ax.set(title="Yaw through the turn", xlabel="time [s]", ylabel="yaw [°]")
    yaw_ax.legend(fontsize=8)
    rate_ax.plot(t[window], ref[window, 5], lw=1.0, label="yaw rate (reference)")
    for tripod, colour in colours.items():
        rate_ax.plot([], [], color=colour, alpha=0.4, lw=6, label=f"tripod {tripod} lifted")
    rate_ax.set(title="Yaw rate: zero whenever six wheels are down", xlabel="time [s]", ylabel="[rad/s]")
    rate_ax.legend(fontsize=8)
    x = a["x"]
    centres, toes = [], []
    for state in x[window][::20]:
        centre, _rotation, feet = t3.world_kinematics(state)
        centres.append(centre)
        toes.append(feet)
    centres, toes = np.asarray(centres), np.asarray(toes)
    for leg, name in enumerate(t3.LEG_NAMES):
        style = "-" if leg in t3.DRIVE_LEGS else ":"
        top.plot(toes[:, leg, 0], toes[:, leg, 1], style, lw=0.8, label=f"{name} wheel")
    top.plot(centres[:, 0], centres[:, 1], "k", lw=1.5, label="body centre")
    top.set(title="From above: wheels and body centre", xlabel="x [m]", ylabel="y [m]", aspect="equal")
    top.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.tight_layout()
    return _save(fig, out, stem)
