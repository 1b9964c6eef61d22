"""The camera: the world-to-pixel transform of a frame, and the view that follows the robot.

The camera follows the robot's (smoothed) centre of mass at a fixed scale, so that the ground
moves under a walking robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sim.config import VOXEL_SIDE
from .recording import Recording


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


__all__ = [
    "View",
    "follow_view",
]
