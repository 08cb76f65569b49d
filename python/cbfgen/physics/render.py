"""Offscreen pictures of physical runs: MuJoCo's renderer (OSMesa, or EGL where a GPU
driver is present) to an animated GIF, runs side by side.

MuJoCo picks its OpenGL back end from ``MUJOCO_GL`` when it is first imported; this
module sets it to ``osmesa`` unless the caller chose one, so import it before anything
else imports ``mujoco`` (``python -m cbfgen.physics`` does).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "osmesa")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])

from pathlib import Path  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image, ImageDraw  # noqa: E402

FRAME_PERIOD = 0.1
"""Simulated time between frames [s]."""

PLAYBACK = 2.0
"""The GIF plays this many times faster than the run."""


class FrameRecorder:
    """Keeps the robot's joint positions every :data:`FRAME_PERIOD` of a run; hook its
    :meth:`__call__` into :func:`cbfgen.physics.loop.run` as ``on_cycle``."""

    def __init__(self, period_cycles: int = int(round(FRAME_PERIOD / 0.001))) -> None:
        self.period = period_cycles
        self.qpos: list[np.ndarray] = []
        self.body_contact: list[bool] = []
        self.model = None

    def __call__(self, k: int, robot) -> None:
        if k % self.period == 0:
            self.model = robot.model
            self.qpos.append(robot.data.qpos.copy())
            self.body_contact.append(robot.contacts()[0])


def render_frames(recorder: FrameRecorder, width: int = 400, height: int = 250) -> list[np.ndarray]:
    """Each recorded pose seen from the robot's left side, the camera following it."""
    model = recorder.model
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.distance, camera.azimuth, camera.elevation = 3.2, 90.0, -12.0
    frames = []
    with mujoco.Renderer(model, height, width) as renderer:
        for qpos in recorder.qpos:
            data.qpos[:] = qpos
            mujoco.mj_forward(model, data)
            camera.lookat[:] = [qpos[0], 0.0, qpos[2] - 0.05]
            renderer.update_scene(data, camera)
            frames.append(renderer.render().copy())
    return frames


def _tiles(rendered, i: int) -> Image.Image:
    tiles = []
    for title, frames, contact in rendered:
        j = min(i, len(frames) - 1)
        tile = Image.fromarray(frames[j])
        draw = ImageDraw.Draw(tile)
        draw.rectangle([0, 0, tile.width, 22], fill=(255, 255, 255))
        draw.text((8, 5), f"{title}   t = {j * FRAME_PERIOD:4.1f} s", fill=(0, 0, 0))
        if contact[j]:
            draw.rectangle([0, 0, tile.width - 1, tile.height - 1], outline=(220, 30, 30), width=5)
            draw.text((8, tile.height - 18), "body touches the terrain", fill=(220, 30, 30))
        tiles.append(tile)
    frame = Image.new("RGB", (sum(t.width for t in tiles), tiles[0].height))
    x = 0
    for tile in tiles:
        frame.paste(tile, (x, 0))
        x += tile.width
    return frame


def write_side_by_side_gif(
    path: Path, columns: list[tuple[str, FrameRecorder]], stills: Path | None = None, still_times=()
) -> int:
    """One GIF of the runs side by side (playing :data:`PLAYBACK` times faster), each
    titled, a red border where its body touches the terrain; the shorter runs hold their
    last frame. With ``stills``, also a PNG of the frames at ``still_times`` [s], one row
    each. Returns the GIF's frame count."""
    rendered = [(title, render_frames(rec), rec.body_contact) for title, rec in columns]
    count = max(len(frames) for _, frames, _ in rendered)
    images = [_tiles(rendered, i).quantize(colors=64, method=Image.Quantize.MEDIANCUT) for i in range(count)]
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(
        path, save_all=True, append_images=images[1:], duration=int(FRAME_PERIOD * 1000 / PLAYBACK), loop=0
    )
    if stills is not None and still_times:
        rows = [_tiles(rendered, min(count - 1, int(round(t / FRAME_PERIOD)))) for t in still_times]
        sheet = Image.new("RGB", (rows[0].width, sum(r.height for r in rows)))
        for k, row in enumerate(rows):
            sheet.paste(row, (0, k * row.height))
        sheet.save(stills, optimize=True)
    return count

