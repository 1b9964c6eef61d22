"""The picture of a gait summary (:mod:`somite.analysis.gait`): each voxel's actuation over time
as a heat map, and the spectra of the actuation and of the centre of mass's velocity."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..analysis.gait import Gait
from ..sim.config import CONTROL_HZ
from .brain import save_figure
from .output import check_output

GAIT_FORMATS = (".png", ".svg")
HEAT_SECONDS = 2.0
"""Seconds of actuation the heat map shows (the whole episode would blur a 10 Hz gait)."""


def draw_gait(gait: Gait, recording, out_path: str | os.PathLike, dpi: int = 110) -> Path:
    """Write the gait picture of ``recording`` (summarised by ``gait``) to ``out_path``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    out_path = check_output(out_path, GAIT_FORMATS)
    n_voxels = len(gait.voxels)
    first = int(round(gait.start * CONTROL_HZ))
    last = min(len(recording.actuation), first + int(HEAT_SECONDS * CONTROL_HZ) + 1)
    act = np.asarray(recording.actuation[first:last], dtype=np.float64).T
    figure = Figure(figsize=(10, 3.2 + 0.18 * n_voxels))
    FigureCanvasAgg(figure)
    heat, spec = figure.subplots(1, 2, gridspec_kw={"width_ratios": [3, 2]})
    image = heat.imshow(act, aspect="auto", cmap="coolwarm", vmin=-1, vmax=1,
                        interpolation="nearest", origin="lower",
                        extent=(first / CONTROL_HZ, (first + act.shape[1]) / CONTROL_HZ,
                                -0.5, n_voxels - 0.5))
    heat.set_yticks(range(n_voxels))
    heat.set_yticklabels([f"{v.voxel} ({v.x},{v.y})" + (" still" if v.still else "")
                          for v in gait.voxels], fontsize=7)
    heat.set_xlabel("time [s]")
    heat.set_ylabel("voxel (x,y)")
    heat.set_title(f"actuation (+1 contracts), {act.shape[1] / CONTROL_HZ:.1f} s from "
                   f"t = {gait.start:g} s", fontsize=9)
    figure.colorbar(image, ax=heat, fraction=0.04, pad=0.01)
    freqs = gait.frequencies
    for v in gait.voxels:
        if not v.still:
            spec.plot(freqs, gait.spectra[v.voxel], lw=0.9, label=f"voxel {v.voxel}")
    peak = float(np.max(gait.stride_spectrum[1:])) if len(freqs) > 1 else 0.0
    if peak > 0:
        spec.plot(freqs, gait.stride_spectrum / peak, color="black", ls="--", lw=1.0,
                  label="centre of mass v_x (scaled)")
    spec.set_xlim(0, CONTROL_HZ / 2)
    spec.set_xlabel("frequency [Hz]")
    spec.set_ylabel("amplitude")
    spec.set_title(f"spectra: main {gait.frequency:.2f} Hz, stride {gait.stride_frequency:.2f}"
                   " Hz", fontsize=9)
    if len(gait.moving) <= 8:
        spec.legend(fontsize=7, frameon=False)
    figure.suptitle(gait.description, fontsize=10)
    figure.tight_layout()
    return save_figure(figure, out_path, dpi)


__all__ = ["GAIT_FORMATS", "draw_gait"]
