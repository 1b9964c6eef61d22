"""A time-lapse strip of a recorded episode: snapshots side by side (paper Figure 4)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from PIL import Image

from ..errors import bad
from .camera import follow_view
from .frame import Frame, Overlay, render_frame
from .recording import Recording


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
    "Strip",
    "render_strip",
]
