"""One frame of a recorded episode, drawn with Pillow (paper Figure 1), and a video's frames.

A frame shows the terrain, every voxel as its deformed quadrilateral coloured by its area ratio
(red contracted, yellow at rest, green expanded), each voxel's sensor readings as a half disc
of sectors at its centre (one sector per sensor, split per reading, radius growing with the
normalised reading, as in Figure 1), the lidar rays as thin red lines, and the time and current
v_x. The camera (:mod:`somite.viz.camera`) follows the robot.

Why Pillow and not matplotlib: a 30 s episode at 30 fps is 900 frames, and a matplotlib figure
per frame costs about 50x more. Drawing happens at ``supersample`` times the size and is then
reduced with a box filter: antialiased edges, and the inside of a flat area keeps its exact
colour (which the tests rely on).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator, Sequence
from typing import NamedTuple

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..errors import bad
from ..limits import MAX_SPEED, MIN_FPS, MIN_SPEED
from ..sim.config import CONTROL_HZ, VOXEL_SIDE
from ..sim.sensor_kinds import SENSORS
from ..sim.terrain import Terrain
from .camera import View, follow_view
from .recording import Recording, lidar_segments

SKY = (236, 242, 248)
GRID = (214, 222, 232)
GROUND = (152, 141, 124)
GROUND_EDGE = (92, 84, 72)
OUTLINE = (45, 45, 45)
RAY = (220, 30, 30)
TEXT = (25, 25, 25)
RED = np.array([214.0, 40.0, 40.0])
YELLOW = np.array([250.0, 222.0, 60.0])
GREEN = np.array([44.0, 168.0, 64.0])
SENSOR_COLOURS = {kind.name: kind.colour for kind in SENSORS}
"""Sensor kind -> RGB of its sectors (:attr:`somite.sim.sensor_kinds.SensorKind.colour`)."""
SECTOR_RADIUS = 0.3
"""Radius of the sensor half disc, as a share of the voxel side."""
GRID_STEP = 5.0
"""Metres between the vertical reference lines that make the camera's motion visible."""


def area_colour(ratio: np.ndarray, delta: float = 0.225) -> np.ndarray:
    """RGB (..., 3) uint8 for area ratios: red at 1 - delta or less, yellow at 1, green at
    1 + delta or more, linear in between (delta: the largest actuated change, config.area_delta).
    """
    t = np.clip((np.asarray(ratio, dtype=np.float64) - 1.0) / max(delta, 1e-9), -1.0, 1.0)
    t = t[..., None]
    colour = np.where(t < 0, YELLOW + (RED - YELLOW) * -t, YELLOW + (GREEN - YELLOW) * t)
    return np.round(colour).astype(np.uint8)


AREA_RAMP = area_colour(np.linspace(0.75, 1.25, 101))
"""(101, 3) every colour a voxel can take, from fully contracted to fully expanded."""


# -- one frame ----------------------------------------------------------------------------------


class Frame(NamedTuple):
    """A rendered frame: control step, time [s], RGB image, and its world-to-pixel view."""

    step: int
    time: float
    image: Image.Image
    view: View


Overlay = Callable[[ImageDraw.ImageDraw, View, Recording, int], None]
"""Something drawn over the robot: called with the canvas, its view, the recording and step."""


def render_frame(
    recording: Recording,
    step: int,
    width: int = 960,
    height: int = 540,
    view: View | None = None,
    overlays: Sequence[Overlay] = (),
    supersample: int = 2,
    sensors: bool = True,
    speed: float = 1.0,
) -> Frame:
    """Draw control step ``step`` of ``recording``.

    Parameters
    ----------
    recording : Recording
    step : int
        0 .. recording.n_steps.
    width, height : int
        Image size [px] (ignored when ``view`` is given).
    view : View, optional
        The camera; :func:`follow_view` by default.
    overlays : sequence of callables
        Drawn after the robot, before the text (e.g. the brain, see :mod:`somite.viz.brain`).
    supersample : int
        Drawing resolution factor (1 = no antialiasing, fastest).
    sensors : bool
        Draw the readings' half discs (off under a brain overlay, which would hide them).
    speed : float
        The video's playback speed, written beside the time when it is not 1.

    Returns
    -------
    Frame
    """
    view = view or follow_view(recording, step, width, height)
    canvas_view = view.supersampled(supersample)
    image = Image.new("RGB", (canvas_view.width, canvas_view.height), SKY)
    draw = ImageDraw.Draw(image)
    _paint_grid(draw, canvas_view, labels=False)
    _paint_terrain(draw, canvas_view, recording.terrain)
    _paint_grid(draw, canvas_view, labels=True)
    quads = recording.quads(step)
    _paint_voxels(draw, canvas_view, quads, recording.area_ratio(step),
                  recording.config.area_delta)
    _paint_rays(draw, canvas_view, recording, step, quads)
    if sensors:
        _paint_sensors(draw, canvas_view, recording, step, quads)
    for overlay in overlays:
        overlay(draw, canvas_view, recording, step)
    _paint_text(draw, canvas_view, recording, step, speed)
    if supersample > 1:
        image = image.reduce(supersample)
    return Frame(step, step / CONTROL_HZ, image, view)


def _font(size: float) -> ImageFont.ImageFont:
    return _font_of_size(max(6, int(round(size))))


@functools.lru_cache(maxsize=16)
def _font_of_size(size: int) -> ImageFont.ImageFont:
    # Pillow's bundled scalable font: no system font needed, the same look everywhere.
    return ImageFont.load_default(size=size)


def _points(view: View, xy: np.ndarray) -> list[tuple[float, float]]:
    return [tuple(p) for p in view.to_pixels(xy).tolist()]


def _paint_grid(draw: ImageDraw.ImageDraw, view: View, labels: bool) -> None:
    # Without fixed marks a followed robot seems to stand still on flat ground.
    font = _font(11 * view.pixel)
    first = math.floor(view.x0 / GRID_STEP) * GRID_STEP
    for x in np.arange(first, view.x1 + GRID_STEP, GRID_STEP):
        column = (x - view.x0) * view.scale
        if not labels:
            draw.line([(column, 0), (column, view.height)], fill=GRID,
                      width=max(1, int(view.pixel)))
        elif round(x / GRID_STEP) % 2 == 0:
            draw.text((column + 3 * view.pixel, view.height - 16 * view.pixel), f"{x:.0f} m",
                      fill=(245, 240, 230), font=font)


def _paint_terrain(draw: ImageDraw.ImageDraw, view: View, terrain: Terrain) -> None:
    lo = max(0, int(np.searchsorted(terrain.xs, view.x0)) - 1)
    hi = min(len(terrain.xs), int(np.searchsorted(terrain.xs, view.x1)) + 1)
    xy = np.stack([terrain.xs[lo:hi], terrain.ys[lo:hi]], axis=1)
    top = _points(view, xy)
    bottom = max(view.height, max(r for _, r in top)) + 10 * view.pixel
    polygon = top + [(top[-1][0], bottom), (top[0][0], bottom)]
    draw.polygon(polygon, fill=GROUND)
    draw.line(top, fill=GROUND_EDGE, width=max(1, int(2 * view.pixel)))


def _paint_voxels(draw, view: View, quads: np.ndarray, ratio: np.ndarray, delta: float) -> None:
    colours = area_colour(ratio, delta)
    outline = max(1, int(round(1.5 * view.pixel)))
    for quad, colour in zip(view.to_pixels(quads).tolist(), colours.tolist()):
        draw.polygon([tuple(p) for p in quad], fill=tuple(colour), outline=OUTLINE, width=outline)


def _paint_rays(draw, view: View, recording: Recording, step: int, quads: np.ndarray) -> None:
    width = max(1, int(round(view.pixel)))
    for start, end in lidar_segments(recording, step, quads):
        draw.line(_points(view, np.stack([start, end])), fill=RAY, width=width)


def _paint_sensors(draw, view: View, recording: Recording, step: int, quads: np.ndarray) -> None:
    # Figure 1: a half disc at the voxel centre, one sector per sensor, one sub-sector per
    # reading, its radius proportional to the reading (normalised to [0, 1]).
    radius = SECTOR_RADIUS * VOXEL_SIDE * view.scale
    centres = view.to_pixels(quads.mean(axis=1))
    thin = max(1, int(round(view.pixel)))
    for v, sensors in enumerate(recording.sensor_groups):
        if not sensors:
            continue
        cx, cy = centres[v]
        draw.pieslice(_box(cx, cy, radius), 180, 360, fill=None, outline=OUTLINE, width=thin)
        span = 180.0 / len(sensors)
        for k, (kind, indices) in enumerate(sensors):
            sub = span / len(indices)
            for j, r in enumerate(indices):
                value = float(np.clip(recording.readings[step, r], 0.0, 1.0))
                if value * radius < 0.5:
                    continue
                start = 180.0 + k * span + j * sub
                draw.pieslice(_box(cx, cy, value * radius), start, start + sub,
                              fill=SENSOR_COLOURS[kind], outline=OUTLINE, width=thin)


def _box(cx: float, cy: float, r: float) -> tuple[float, float, float, float]:
    return (cx - r, cy - r, cx + r, cy + r)


def _paint_text(draw, view: View, recording: Recording, step: int, speed: float = 1.0) -> None:
    size = max(11.0, view.height / view.pixel / 30) * view.pixel
    font = _font(size)
    text = f"t = {step / CONTROL_HZ:5.2f} s   v_x = {recording.velocity_at(step):+5.2f} m/s"
    if speed != 1.0:
        text += f"   ({speed:g}x)"
    pad = 0.4 * size
    box = draw.textbbox((pad, pad), text, font=font)
    draw.rectangle((box[0] - pad / 2, box[1] - pad / 2, box[2] + pad / 2, box[3] + pad / 2),
                   fill=(255, 255, 255))
    draw.text((pad, pad), text, fill=TEXT, font=font)
    name = recording.terrain.name
    small = _font(0.8 * size)
    right = draw.textbbox((0, 0), name, font=small)[2]
    draw.text((view.width - right - pad, pad), name, fill=TEXT, font=small)


# -- many frames --------------------------------------------------------------------------------


def frame_steps(n_steps: int, fps: float, speed: float = 1.0) -> np.ndarray:
    """Control steps shown by a video at ``fps`` (<= 60) played at ``speed`` times real time
    (0.05 .. 4): round(duration / speed * fps) frames, frame k showing time k * speed / fps; at
    30 fps and speed 1 every other step, at speed 0.25 each step for two frames."""
    if not MIN_FPS <= fps <= CONTROL_HZ:
        raise bad("fps", fps, f"must be in [{MIN_FPS:g}, {CONTROL_HZ:g}] (the control rate)")
    check_speed(speed)
    n_frames = max(1, int(round(n_steps * fps / (CONTROL_HZ * speed))))
    shown = np.round(np.arange(n_frames) * (CONTROL_HZ * speed / fps)).astype(int)
    return np.minimum(shown, n_steps)


def check_speed(speed: float) -> float:
    """``speed`` if it is a playback speed somite offers, else a one-line error."""
    if not MIN_SPEED <= speed <= MAX_SPEED:
        raise bad("speed", speed, f"must be in [{MIN_SPEED:g}, {MAX_SPEED:g}] (times real time)")
    return float(speed)


def render_frames(
    recording: Recording,
    fps: float = 30,
    width: int = 960,
    height: int = 540,
    overlays: Sequence[Overlay] = (),
    supersample: int = 2,
    sensors: bool = True,
    speed: float = 1.0,
) -> Iterator[Frame]:
    """The frames of a video of ``recording`` at ``fps`` played at ``speed``, one at a time
    (see :func:`frame_steps`); in slow motion a step shown by several frames is drawn once."""
    previous = None
    for step in frame_steps(recording.n_steps, fps, speed):
        if previous is None or previous.step != step:
            previous = render_frame(recording, int(step), width, height, overlays=overlays,
                                    supersample=supersample, sensors=sensors, speed=speed)
        yield previous


__all__ = [
    "AREA_RAMP",
    "Frame",
    "Overlay",
    "area_colour",
    "check_speed",
    "frame_steps",
    "render_frame",
    "render_frames",
]
