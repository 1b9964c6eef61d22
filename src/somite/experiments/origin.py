"""Where a saved genome was made, and the simulation settings it was made under.

A genome given to ``evaluate``, ``show``, ``reassemble``, ``reoptimize`` or ``module export``
is judged on the settings it evolved under unless the user says otherwise: a robot evolved
for 10 s with the ``original-code`` preset on flat ground, re-run for 30 s with ``paper`` on
hills, is another experiment. The settings are read from the folder the genome is in:

- a run directory (or a genome file inside one, such as its ``best.json``): its
  ``config.json`` gives duration, transient, preset and training terrain;
- a reassembly folder (``reassembled.json`` beside a ``report.json``): the settings its
  validation ran with, and the training terrain its donors' runs shared (recorded as each
  donor's ``terrain`` in ``report.json``).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

from .._io import read_json
from ..errors import SomiteError
from ..tasks.distributions import parse_distribution
from .logfile import last_validation


@dataclass(frozen=True)
class Origin:
    """The settings a genome was made under; None where its folder does not say.

    Attributes
    ----------
    source : str
        What the settings were read from (``run demo/run``, ``reassembly out``), or "".
    duration, transient : float or None
        Episode length and start of the measured interval [s].
    preset : str or None
        Simulator preset.
    terrain : str or None
        A run's training terrains (a distribution name, :mod:`somite.tasks.distributions`);
        a reassembly's: its donors' runs', when they shared one.
    modules : str or None
        A run's partition for omega, when it had one.
    validation_velocity : float or None
        A run's last logged validation velocity.
    """

    source: str = ""
    duration: float | None = None
    transient: float | None = None
    preset: str | None = None
    terrain: str | None = None
    modules: str | None = None
    validation_velocity: float | None = None

    def options(self) -> dict:
        """The settings it has, by option name (``duration``, ``transient``, ``preset``)."""
        values = {"duration": self.duration, "transient": self.transient, "preset": self.preset}
        return {key: value for key, value in values.items() if value is not None}

    def fixed_terrain(self) -> str | None:
        """The run's training terrain when it trained on one fixed terrain, else None."""
        if self.terrain is None:
            return None

        try:
            distribution = parse_distribution(self.terrain)
        except SomiteError:
            return None
        return None if distribution.is_random else distribution.name


def origin_of(path: str | Path) -> Origin:
    """The :class:`Origin` of the genome at ``path`` (a genome file or a run directory)."""
    target = Path(path)
    folder = target if target.is_dir() else target.parent
    if (folder / "config.json").is_file():
        return _run_origin(folder)
    if (folder / "report.json").is_file() and (folder / "reassembled.json").is_file():
        return _reassembly_origin(folder)
    return Origin()


def _run_origin(folder: Path) -> Origin:
    data = read_json(folder / "config.json", "config")
    if not isinstance(data, dict):
        return Origin()
    return Origin(
        source=f"run {folder}",
        duration=_number(data.get("duration")),
        transient=_number(data.get("transient")),
        preset=_text(data.get("preset")),
        terrain=_text(data.get("terrain")),
        modules=_text(data.get("modules")),
        validation_velocity=_last_validation(folder),
    )


def _reassembly_origin(folder: Path) -> Origin:
    data = read_json(folder / "report.json", "report")
    settings = data.get("validation") if isinstance(data, dict) else None
    if not isinstance(settings, dict):
        return Origin()
    donors = data.get("donors")
    terrains = {_text(d.get("terrain")) if isinstance(d, dict) else None
                for d in (donors if isinstance(donors, list) else [])}
    return Origin(
        source=f"reassembly {folder}",
        duration=_number(settings.get("duration")),
        transient=_number(settings.get("transient")),
        preset=_text(settings.get("preset")),
        terrain=terrains.pop() if len(terrains) == 1 else None,
    )


def shared_origin(paths) -> Origin:
    """What the runs of the genomes at ``paths`` (donors) all had: their settings when every
    one has the same, their training terrain likewise, ``source`` naming them all
    (``run a, run b``); an empty Origin when any has no run or none is shared."""
    origins = [origin_of(path) for path in paths]
    if not origins or not all(origin.source for origin in origins):
        return Origin()
    options = {tuple(sorted(origin.options().items())) for origin in origins}
    terrains = {origin.terrain for origin in origins}
    settings = dict(options.pop()) if len(options) == 1 else {}
    terrain = terrains.pop() if len(terrains) == 1 else None
    if not settings and terrain is None:
        return Origin()
    return Origin(source=", ".join(origin.source for origin in origins), terrain=terrain,
                  **settings)


def _last_validation(folder: Path) -> float | None:
    """The last validation velocity in the run's whole log.csv (None without one, or when the
    last one is not finite: the latest best's reference speed is then unknown)."""
    log = folder / "log.csv"
    if not log.is_file():
        return None
    try:
        rows = list(csv.DictReader(io.StringIO(log.read_text(errors="replace"))))
    except (OSError, csv.Error):
        return None
    value = last_validation(rows)
    return value if value is not None and math.isfinite(value) else None


def _number(value) -> float | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return None
    return None


def _text(value) -> str | None:
    return value if isinstance(value, str) and value else None


__all__ = ["Origin", "origin_of", "shared_origin"]
