"""The paper's Figs. 7–10 from physical runs, and the tracking error, as PNG and SVG."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

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
