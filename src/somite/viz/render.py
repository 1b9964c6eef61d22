"""Frames of a recorded episode, drawn with Pillow (paper Figure 1 and Figure 4).

A frame shows the terrain, every voxel as its deformed quadrilateral coloured by its area ratio
(red contracted, yellow at rest, green expanded), each voxel's sensor readings as a half disc
of sectors at its centre (one sector per sensor, split per reading, radius growing with the
normalised reading, as in Figure 1), the lidar rays as thin red lines, and the time and current
v_x. The camera follows the robot's (smoothed) centre of mass at a fixed scale.

Why Pillow and not matplotlib: a 30 s episode at 30 fps is 900 frames, and a matplotlib figure
per frame costs about 50x more. Drawing happens at ``supersample`` times the size and is then
reduced with a box filter: antialiased edges, and the inside of a flat area keeps its exact
colour (which the tests rely on).

This module reads recordings only; :mod:`somite.viz.video` runs the simulation through the
public :func:`somite.tasks.locomotion.simulate`. It also holds :func:`atomic_output`, used by
every viz writer so that no output file is ever left half-written.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..errors import bad
from ..sim.body import Body
from ..sim.config import CONTROL_HZ, VOXEL_SIDE, SimConfig
from ..sim.system import geometry
from ..sim.terrain import Terrain

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
SENSOR_COLOURS = {
    "area": (255, 255, 255),
    "touch": (20, 20, 20),
    "velocity": (40, 100, 210),
    "lidar": (220, 30, 30),
}
SECTOR_RADIUS = 0.3
"""Radius of the sensor half disc, as a share of the voxel side."""
GRID_STEP = 5.0
"""Metres between the vertical reference lines that make the camera's motion visible."""
VELOCITY_WINDOW = 30
"""Control steps (0.5 s) over which the on-screen v_x is averaged."""
CAMERA_WINDOW = 15
"""Half-width in control steps of the moving average the camera follows (no jitter)."""


# -- output -------------------------------------------------------------------------------------


def check_output(path: str | os.PathLike, formats: Sequence[str]) -> Path:
    """``path`` as a Path, or a one-line error if its extension or folder is wrong."""
    path = Path(path)
    if path.suffix.lower() not in formats:
        raise bad("out", str(path), f"unknown extension; use one of {list(formats)}")
    if not path.parent.is_dir():
        raise bad("out", str(path), "its folder does not exist")
    return path


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same extension); rename it onto ``path`` only
    when the block succeeds, otherwise delete it."""
    path = Path(path)
    tmp = path.parent / f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}{path.suffix}"
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


# -- what is drawn ------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Recording:
    """One robot's recorded episode (T = recorded control steps + 1).

    Attributes
    ----------
    body, terrain, config
        What was simulated.
    corners : numpy.ndarray
        (V, 4) point indices of each voxel's corners SW, SE, NE, NW.
    pos : numpy.ndarray
        (T, P, 2) corner positions [m].
    actuation : numpy.ndarray
        (T, V) actuation in [-1, 1] (+1 contracts).
    readings : numpy.ndarray
        (T, R) normalised noisy readings, in ``body.readings`` order.
    contact : numpy.ndarray
        (T, P) bool, corners touching the ground.
    com : numpy.ndarray
        (T, 2) centre of mass [m].
    velocity : float
        The episode's v_x over [transient, end] (NaN when the episode blew up).
    complete : bool
        False when the simulation went non-finite and the recording stops before it did.
    """

    body: Body
    terrain: Terrain
    config: SimConfig
    corners: np.ndarray
    pos: np.ndarray
    actuation: np.ndarray
    readings: np.ndarray
    contact: np.ndarray
    com: np.ndarray
    velocity: float = math.nan
    complete: bool = True

    @classmethod
    def from_trace(cls, trace, robot: int, body: Body, terrain: Terrain, config: SimConfig,
                   velocity: float = math.nan) -> Recording:
        """Robot ``robot`` of a trace recorded with ``simulate(..., record=True)``.

        The recording is cut before the first step with a non-finite position, if any.
        """
        if len(trace.pos) == 0:
            raise ValueError("the trace was not recorded; simulate with record=True")
        n_points = len(geometry(body).points)
        n_voxels = body.shape.n_voxels
        pos = trace.pos[robot][:, :n_points]
        finite = np.isfinite(pos).all(axis=(1, 2)) & np.isfinite(trace.com[robot]).all(axis=1)
        end = len(pos) if finite.all() else max(1, int(np.argmin(finite)))
        return cls(
            body=body,
            terrain=terrain,
            config=config,
            corners=geometry(body).corners.astype(np.int64),
            pos=pos[:end],
            actuation=trace.actuation[robot][:end, :n_voxels],
            readings=trace.readings[robot][:end, : body.n_readings],
            contact=trace.contact[robot][:end, :n_points],
            com=trace.com[robot][:end],
            velocity=float(velocity),
            complete=end == len(pos),
        )

    @property
    def n_steps(self) -> int:
        """Recorded control steps (rows minus the initial state)."""
        return len(self.pos) - 1

    def quads(self, step: int) -> np.ndarray:
        """(V, 4, 2) voxel corners SW, SE, NE, NW at ``step`` [m]."""
        return self.pos[step][self.corners]

    def area_ratio(self, step: int) -> np.ndarray:
        """(V,) each voxel's area over its rest area (shoelace formula)."""
        return area_ratio(self.quads(step))

    def velocity_at(self, step: int, window: int = VELOCITY_WINDOW) -> float:
        """v_x of the centre of mass over the last ``window`` steps [m/s] (0 at step 0)."""
        start = max(0, step - window)
        if step == start:
            return 0.0
        return float((self.com[step, 0] - self.com[start, 0]) * CONTROL_HZ / (step - start))

    @cached_property
    def camera(self) -> np.ndarray:
        """(T, 2) the point the camera follows: the centre of mass, moving-averaged."""
        return moving_average(self.com, CAMERA_WINDOW)

    @cached_property
    def sensor_groups(self) -> list[list[tuple[str, list[int]]]]:
        """Per voxel, per sensor: (kind, indices of its readings in ``readings``)."""
        groups: list[list[tuple[str, list[int]]]] = [[] for _ in self.body.shape.voxels]
        for r, reading in enumerate(self.body.readings):
            sensors = groups[reading.voxel]
            if reading.component == 0:
                sensors.append((reading.kind, []))
            sensors[-1][1].append(r)
        return groups


def area_ratio(quads: np.ndarray) -> np.ndarray:
    """(..., V) area of quadrilaterals (..., V, 4, 2) over the rest area VOXEL_SIDE**2."""
    x = quads[..., 0]
    y = quads[..., 1]
    twice = np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)
    return 0.5 * twice / VOXEL_SIDE**2


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


def moving_average(values: np.ndarray, half: int) -> np.ndarray:
    """Centred moving average along axis 0 over 2 * half + 1 rows, shrinking at the ends."""
    n = len(values)
    cumulative = np.concatenate([np.zeros((1,) + values.shape[1:]), np.cumsum(values, axis=0)])
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) + half + 1, 0, n)
    count = (hi - lo).reshape((-1,) + (1,) * (values.ndim - 1))
    return (cumulative[hi] - cumulative[lo]) / count


# -- the camera ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class View:
    """The world-to-pixel transform of one frame.

    Pixel column ``left + (x - x0) * scale``, row ``top + height - (y - y0) * scale``: pixel
    (i, j) covers columns [i, i + 1) and rows [j, j + 1), row 0 at the top.

    Attributes
    ----------
    x0, y0 : float
        World point [m] at the bottom-left corner of the frame.
    scale : float
        Pixels per metre.
    width, height : int
        Frame size [px].
    left, top : int
        Offset of the frame inside a larger image (a tile of a time-lapse strip).
    pixel : float
        Drawing pixels per output pixel (the supersampling factor while drawing, else 1).
    """

    x0: float
    y0: float
    scale: float
    width: int
    height: int
    left: int = 0
    top: int = 0
    pixel: float = 1.0

    def to_pixels(self, xy: np.ndarray) -> np.ndarray:
        """World points (..., 2) [m] -> pixel coordinates (..., 2) (column, row), as floats."""
        xy = np.asarray(xy, dtype=np.float64)
        column = self.left + (xy[..., 0] - self.x0) * self.scale
        row = self.top + self.height - (xy[..., 1] - self.y0) * self.scale
        return np.stack([column, row], axis=-1)

    def to_world(self, pixels: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_pixels`."""
        pixels = np.asarray(pixels, dtype=np.float64)
        x = self.x0 + (pixels[..., 0] - self.left) / self.scale
        y = self.y0 + (self.top + self.height - pixels[..., 1]) / self.scale
        return np.stack([x, y], axis=-1)

    def supersampled(self, factor: int) -> View:
        """The same view on a canvas ``factor`` times larger (offsets dropped)."""
        return View(self.x0, self.y0, self.scale * factor, self.width * factor,
                    self.height * factor, 0, 0, self.pixel * factor)

    @property
    def x1(self) -> float:
        """World x at the right edge [m]."""
        return self.x0 + self.width / self.scale


def follow_view(recording: Recording, step: int, width: int, height: int,
                margin: float = 2.4) -> View:
    """The frame at ``step``: a fixed scale showing ``margin`` times the body's size, centred
    horizontally on the smoothed centre of mass, which sits 38 % up from the bottom."""
    shape = recording.body.shape
    span = margin * VOXEL_SIDE * max(shape.width, shape.height * width / height, 4)
    scale = width / span
    cx, cy = recording.camera[step]
    return View(cx - 0.5 * width / scale, cy - 0.38 * height / scale, scale, width, height)


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
    _paint_text(draw, canvas_view, recording, step)
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


def voxel_angles(quads: np.ndarray) -> np.ndarray:
    """(V,) each voxel's orientation [rad]: the mean direction of its bottom and top sides,
    as the voxel-frame sensors compute it."""
    side = quads[:, 1] - quads[:, 0] + quads[:, 2] - quads[:, 3]
    return np.arctan2(side[:, 1], side[:, 0])


def lidar_segments(recording: Recording, step: int, quads: np.ndarray | None = None):
    """World segments [m] of every lidar ray at ``step``: a list of (start (2,), end (2,)).

    A ray starts at its voxel's centre, points along config.lidar_angles (turned with the
    voxel when lidar_frame is "voxel"), and is as long as its reading times lidar_range.
    """
    quads = recording.quads(step) if quads is None else quads
    config = recording.config
    angles = np.asarray(config.lidar_angles, dtype=np.float64)
    turn = voxel_angles(quads) if config.lidar_frame == "voxel" else np.zeros(len(quads))
    segments = []
    for v, sensors in enumerate(recording.sensor_groups):
        for kind, indices in sensors:
            if kind != "lidar":
                continue
            centre = quads[v].mean(axis=0)
            length = np.clip(recording.readings[step, indices], 0.0, 1.0) * config.lidar_range
            for angle, reach in zip(angles + turn[v], length):
                end = centre + reach * np.array([math.cos(angle), math.sin(angle)])
                segments.append((centre, end))
    return segments


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


def _paint_text(draw, view: View, recording: Recording, step: int) -> None:
    size = max(11.0, view.height / view.pixel / 30) * view.pixel
    font = _font(size)
    text = f"t = {step / CONTROL_HZ:5.2f} s   v_x = {recording.velocity_at(step):+5.2f} m/s"
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


def frame_steps(n_steps: int, fps: float) -> np.ndarray:
    """Control steps shown by a video at ``fps`` (<= 60): round(duration * fps) frames, frame k
    showing time k / fps; at 30 fps every other step."""
    if not 0 < fps <= CONTROL_HZ:
        raise bad("fps", fps, f"must be in (0, {CONTROL_HZ:g}] (the control rate)")
    n_frames = max(1, int(round(n_steps * fps / CONTROL_HZ)))
    return np.minimum(np.round(np.arange(n_frames) * CONTROL_HZ / fps).astype(int), n_steps)


def render_frames(
    recording: Recording,
    fps: float = 30,
    width: int = 960,
    height: int = 540,
    overlays: Sequence[Overlay] = (),
    supersample: int = 2,
    sensors: bool = True,
) -> Iterator[Frame]:
    """The frames of a video of ``recording`` at ``fps``, one at a time (see
    :func:`frame_steps`)."""
    for step in frame_steps(recording.n_steps, fps):
        yield render_frame(recording, int(step), width, height, overlays=overlays,
                           supersample=supersample, sensors=sensors)


class Strip(NamedTuple):
    """A time-lapse: one image of tiles side by side, and each tile's frame (its view carries
    the tile's offset in the strip)."""

    image: Image.Image
    frames: list[Frame]


STRIP_GAP = 4
"""Pixels between two tiles of a strip."""


def render_strip(
    recording: Recording,
    n_frames: int,
    tile_width: int = 320,
    tile_height: int = 240,
    overlays: Sequence[Overlay] = (),
    supersample: int = 2,
    sensors: bool = True,
) -> Strip:
    """A time-lapse like the paper's Figure 4: ``n_frames`` snapshots evenly spread over the
    episode (first and last included), left to right in time, each tile following the robot.

    The views in :attr:`Strip.frames` carry their tile's offset, so they map the world straight
    into the strip's pixels.
    """
    if n_frames < 1:
        raise bad("frames", n_frames, "must be at least 1")
    steps = np.round(np.linspace(0, recording.n_steps, n_frames)).astype(int)
    width = n_frames * tile_width + (n_frames - 1) * STRIP_GAP
    strip = Image.new("RGB", (width, tile_height), (255, 255, 255))
    frames = []
    for k, step in enumerate(steps):
        view = follow_view(recording, int(step), tile_width, tile_height, margin=1.7)
        frame = render_frame(recording, int(step), view=view, overlays=overlays,
                             supersample=supersample, sensors=sensors)
        left = k * (tile_width + STRIP_GAP)
        strip.paste(frame.image, (left, 0))
        frames.append(frame._replace(view=replace(view, left=left)))
    return Strip(strip, frames)


__all__ = [
    "Frame",
    "Overlay",
    "Recording",
    "Strip",
    "View",
    "AREA_RAMP",
    "area_colour",
    "area_ratio",
    "atomic_output",
    "check_output",
    "follow_view",
    "frame_steps",
    "lidar_segments",
    "moving_average",
    "render_frame",
    "render_frames",
    "render_strip",
    "voxel_angles",
]
