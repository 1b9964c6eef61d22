"""How much a command is asked to do, checked before it starts: it finishes, or it says so.

Every size somite accepts is within :mod:`somite.limits`, but sizes multiply: a population of
10,000 bodies of 32 x 32 voxels for 600 s episodes is within every limit and would run for
years. Before a command simulates or draws, it estimates its work and memory:

- **time**: robot-control-steps, weighted by body size (a step of a robot costs about in
  proportion to its voxels), at the throughput of BENCHMARKS.md's 2-core machine. More than
  :data:`MAX_HOURS` there needs ``--yes``: the paper's own run (about 3 h) passes without.
- **memory**: a batch of robots (:data:`BYTES_PER_VOXEL` a voxel) and the frames of a GIF or a
  time-lapse strip, which are held whole; more than half of this machine's memory is refused,
  ``--yes`` or not, as it would end in a MemoryError or the machine swapping.
"""

from __future__ import annotations

import os

from .errors import bad

STEPS_PER_CORE_SECOND = 50_000
"""Robot-control-steps of the worm (12 voxels) one core simulates a second: BENCHMARKS.md's
108k-117k a second on 2 cores of an AMD EPYC (kernel round 2, 2026-12-04), halved and rounded
down, as the project's other machines ran the same kernel up to 25% slower. Campaigns scale it
by their cores."""
REFERENCE_VOXELS = 12
REFERENCE_CORES = 2
MAX_HOURS = 12.0
"""Longest work a command starts without ``--yes``, in hours on :data:`REFERENCE_CORES` cores."""
BYTES_PER_VOXEL = 4096
"""Memory of one voxel of one robot in a batch (state, joints, contacts, controller), measured
with tracemalloc: 1.3-4 KB from 10 to 400 robots of 12 to 400 voxels; the upper end."""
PIXELS_PER_SECOND = 3e7
"""Pixels a second the renderer draws (a 960 x 540 frame in about 17 ms), for videos."""
BYTES_PER_HELD_PIXEL = 4.5
"""A GIF holds every frame (one palette byte a pixel, and its RGB original while it is
quantised); a strip every tile (RGB). A 60 s GIF of 960 x 540 at 30 fps peaked at 4.1 GB:
4.4 bytes a pixel."""


def hours(robot_steps: float, voxels: float = REFERENCE_VOXELS,
          cores: int = REFERENCE_CORES) -> float:
    """Hours that ``robot_steps`` robot-control-steps of ``voxels``-voxel bodies take."""
    worm_steps = float(robot_steps) * max(float(voxels), 1.0) / REFERENCE_VOXELS
    return worm_steps / (STEPS_PER_CORE_SECOND * cores) / 3600


def about(seconds: float) -> str:
    """A rough duration, in the unit that keeps it short."""
    if seconds < 90:
        return f"~{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"~{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"~{seconds / 3600:.1f} h"
    if seconds < 2 * 365 * 86400:
        return f"~{seconds / 86400:.0f} days"
    return f"~{seconds / (365 * 86400):.0f} years"


def check_time(what: str, estimated_hours: float, yes: bool) -> None:
    """Refuse work longer than :data:`MAX_HOURS` unless ``yes``."""
    if estimated_hours > MAX_HOURS and not yes:
        raise bad("yes", False, f"{what} would take {about(estimated_hours * 3600)} on "
                  f"{REFERENCE_CORES} cores (BENCHMARKS.md's rate), more than {MAX_HOURS:g} h; "
                  "give --yes to start it anyway")


def check_steps(what: str, robot_steps: float, voxels: float, yes: bool) -> None:
    """:func:`check_time` of ``robot_steps`` robot-control-steps of ``voxels``-voxel bodies."""
    check_time(what, hours(robot_steps, voxels), yes)


def check_memory(what: str, needed: float) -> None:
    """Refuse work whose memory ``needed`` [bytes] is over half of this machine's."""
    total = machine_memory()
    if total and needed > total / 2:
        raise bad("memory", f"{needed / 2**30:.1f} GiB",
                  f"{what} needs more than half of this machine's {total / 2**30:.0f} GiB")


def check_batch(robots: int, voxels: int) -> None:
    """:func:`check_memory` of a batch of ``robots`` robots of ``voxels`` voxels."""
    check_memory(f"a batch of {robots} robots of {voxels} voxels",
                 float(robots) * voxels * BYTES_PER_VOXEL)


def machine_memory() -> float:
    """This machine's physical memory [bytes]; 0 when it cannot be told."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE")) * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0.0


__all__ = ["MAX_HOURS", "STEPS_PER_CORE_SECOND", "about", "check_batch", "check_memory",
           "check_steps", "check_time", "hours", "machine_memory"]
