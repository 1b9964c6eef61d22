"""Locomotion: simulate a batch of robots and measure how fast they go.

Fitness is the mean x-velocity of the centre of mass over [transient, duration]
(paper eq. 2): v_x = (x_c(duration) - x_c(transient)) / (duration - transient).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..brain.control import Controller, Controllers, compile_controllers
from ..brain.controllers import GraphArrays
from ..brain.kinds import ACTUATOR, HIDDEN, RELAY, SENSOR
from ..budget import check_batch
from ..errors import bad
from ..limits import MAX_BATCH
from ..sim.body import Body
from ..sim.config import CONTROL_HZ, SimConfig, pack_params
from ..sim.sensors import noise_table
from ..sim.system import System, compile_system
from ..sim.terrain import Terrain
from . import arguments
from .backends import BACKENDS, get_backend
from .episode import (
    D_FLIPPED,
    D_MAX_GAP,
    D_MAX_TILT,
    D_MIN_GAP,
    SETTLE_STEPS,
    STATUS_OK,
    Trace,
    new_trace,
)


@dataclass(frozen=True)
class Outcome:
    """What one episode says about one robot (lengths in m, speeds in m/s)."""

    velocity: float
    distance: float
    final_com: tuple[float, float]
    max_speed: float
    """Highest speed of any of the robot's rigid blocks (four 1.2 m blocks a voxel) over the
    episode [m/s]. Voxels deforming at a few hertz move their blocks fast: a 2 Hz sine worm's
    reach 25 m/s, smoothly."""
    finite: bool
    min_signed_area_ratio: float = math.nan
    """Smallest signed area of a voxel over its rest area (< 0: a voxel turned inside out)."""
    max_tilt_deg: float = math.nan
    """Largest |angle| of the line from the leftmost column's centre to the rightmost's, after
    the first 2 s (> 90: the robot was on its side or upside down)."""
    flipped_fraction: float = math.nan
    """Share of the scored steps (after ``transient``) with that angle over 90 degrees."""
    max_height: float = math.nan
    """Highest that the robot's lowest block corner got above the ground, after the first 2 s
    [m]: how high it jumped."""
    min_height: float = math.nan
    """Lowest that it got, after the first 2 s [m]. Measured vertically, from the corner to the
    terrain's line at the corner's x: < 0 is a corner inside the ground, as a block found in
    contact only after a 1/60 s step that took it into the ground (a block landing at 10 m/s
    goes 0.17 m in a step; the position passes push it out over the next steps), or a corner
    against one of the two end walls, whose faces are so steep (10 m across for 100 m up) that
    a corner 6 cm inside one reads 0.6 m below its line. > 0: the robot never touched."""
    non_finite: int = 0
    """Control steps at which a controller output (actuation) or the physics state (corner
    positions, velocities) held a NaN or an infinity. The episode stops at the first
    non-finite state (``finite`` False, v_x NaN); a non-finite actuation is clamped to [-1, 1]
    by the physics (NaN as -1) and the episode goes on, so its v_x is not the controller's."""

    def to_dict(self) -> dict:
        return {
            "velocity": self.velocity,
            "distance": self.distance,
            "final_com": list(self.final_com),
            "max_speed": self.max_speed,
            "finite": self.finite,
            "min_signed_area_ratio": self.min_signed_area_ratio,
            "max_tilt_deg": self.max_tilt_deg,
            "flipped_fraction": self.flipped_fraction,
            "max_height": self.max_height,
            "min_height": self.min_height,
            "non_finite": self.non_finite,
        }


OUTCOME_UNITS = {
    "velocity": ("m/s", "v_x: mean forward velocity over [transient, end]"),
    "distance": ("m", "forward travel of the centre of mass, whole episode"),
    "final_com": ("m", "centre of mass (x, y) at the end"),
    "max_speed": ("m/s", "fastest any rigid block moved, at any step"),
    "finite": ("", "False: the state went NaN or infinite; stopped"),
    "min_signed_area_ratio": ("", "smallest voxel area / rest area (< 0: inside out)"),
    "max_tilt_deg": ("deg", "largest tilt after 2 s (> 90: on its side)"),
    "flipped_fraction": ("", "share of scored steps tilted past 90 deg"),
    "max_height": ("m", "highest its lowest block corner got after 2 s"),
    "min_height": ("m", "lowest it got (< 0: into the ground or a wall)"),
    "non_finite": ("control steps", "steps with a NaN or infinite actuation or state"),
}
"""Every :meth:`Outcome.to_dict` key: its unit ("" for a pure number or a flag) and what it
is in a few words, as ``somite simulate`` prints it (its ``--json`` carries the units as
``units``). docs/guide.md ("Honest numbers") says more on each diagnostic; ``min_height`` is a
vertical distance, see :attr:`Outcome.min_height`."""


def outcomes(trace: Trace, config: SimConfig) -> list[Outcome]:
    """Per-robot :class:`Outcome` from a finished trace."""
    start = config.transient_steps
    end = config.n_steps
    span = (end - start) / CONTROL_HZ
    result = []
    for b in range(trace.com.shape[0]):
        com = trace.com[b]
        finite = bool(trace.status[b] == STATUS_OK)
        velocity = (com[end, 0] - com[start, 0]) / span if finite else math.nan
        observed = config.n_steps > SETTLE_STEPS and finite
        d = trace.diagnostics[b]
        result.append(
            Outcome(
                velocity=float(velocity),
                distance=float(com[end, 0] - com[0, 0]) if finite else math.nan,
                final_com=(float(com[end, 0]), float(com[end, 1])),
                max_speed=float(trace.max_speed[b]),
                finite=finite,
                min_signed_area_ratio=float(trace.min_area[b]),
                max_tilt_deg=float(d[D_MAX_TILT]) if observed else math.nan,
                flipped_fraction=float(d[D_FLIPPED]) / (end - start) if observed else math.nan,
                max_height=float(d[D_MAX_GAP]) if observed else math.nan,
                min_height=float(d[D_MIN_GAP]) if observed else math.nan,
                non_finite=int(trace.non_finite[b]),
            )
        )
    return result


def run(
    system: System,
    controllers: Controllers,
    config: SimConfig,
    seeds: Sequence[int],
    record: bool = False,
    backend: str = "cpu",
) -> Trace:
    """Run a compiled batch; the lowest-level entry point (no checks, no Python objects).
    ``backend``: a name in :data:`somite.tasks.backends.BACKENDS`."""
    runner = get_backend(backend)
    if record and not runner.records:
        recording = [name for name, b in BACKENDS.items() if b.records]
        raise bad("backend", backend, f"cannot record an episode: use {' or '.join(recording)}")
    seeds_arr = np.asarray(seeds, dtype=np.uint64)
    trace = new_trace(len(seeds_arr), config.n_steps, system, record)
    runner.run(system, controllers, pack_params(config), noise_table(config), seeds_arr,
               config.n_steps, trace)
    return trace


def simulate_batch(
    bodies: Sequence[Body],
    terrains: Sequence[Terrain],
    controllers: Sequence[Controller],
    config: SimConfig | None = None,
    seeds: Sequence[int] | int = 0,
    record: bool = False,
    backend: str = "cpu",
) -> tuple[list[Outcome], Trace]:
    """Simulate robot b = (bodies[b], terrains[b], controllers[b]) for every b, in one batch.

    ``seeds`` seeds each robot's sensor noise (one int seeds them all alike; unused with
    ``noise_stream = "java-random-0"``). With ``record`` the trace also holds every step's
    corner positions, actuation, readings and contacts (``cpu`` backend only).
    """
    config = arguments.sim_config("config", config)
    bodies = checks.items("bodies", bodies, MAX_BATCH, least=1)
    n = len(bodies)
    for name, listed in (("terrains", terrains), ("controllers", controllers)):
        if len(checks.items(name, listed, MAX_BATCH)) != n:
            raise bad(name, f"{len(listed)} {name}", f"need one per body ({n})")
    terrains = [checks.instance(f"terrains[{i}]", t, Terrain, "a somite Terrain "
                                "(somite.parse_terrain(name))") for i, t in enumerate(terrains)]
    record = checks.flag("record", record)
    backend = arguments.backend("backend", backend)
    for i, body in enumerate(bodies):
        arguments.body(f"bodies[{i}]", body)
    check_batch(n, max(b.shape.n_voxels for b in bodies))
    system, ctrl, seeds = compile_batch(bodies, terrains, controllers, config, seeds)
    trace = run(system, ctrl, config, seeds, record, backend)
    return outcomes(trace, config), trace


def compile_batch(
    bodies: Sequence[Body],
    terrains: Sequence[Terrain],
    controllers: Sequence[Controller],
    config: SimConfig,
    seeds: Sequence[int] | int,
) -> tuple[System, Controllers, list[int]]:
    """A batch of robot b = (bodies[b], terrains[b], controllers[b]) compiled for the kernel,
    and its noise seeds, one per robot (one int: the same for all), checked."""
    n = len(bodies)
    seeds = checks.seeds("seeds", seeds, n)
    for b, (body, controller) in enumerate(zip(bodies, controllers)):
        arguments.body(f"bodies[{b}]", body)
        check_fits(f"controllers[{b}]", controller, body)
    system = compile_system(bodies, terrains, config.start_gap)
    ctrl = compile_controllers(controllers, [b.shape.n_voxels for b in bodies])
    return system, ctrl, seeds


def check_fits(field: str, controller, body: Body) -> None:
    """Refuse a graph controller that is not ``body``'s: compiled for another body, or whose
    nodes refer to readings or voxels that ``body`` lacks (the kernel would read past them).
    Any other controller fits any body (a table is checked for its width when padded)."""
    if not isinstance(controller, GraphArrays):
        return
    if controller.body is not None and controller.body is not body and controller.body != body:
        raise bad(field, f"a controller of body {controller.body.shape.grid_string()}",
                  f"its robot's body is {body.shape.grid_string()}")
    kind, ref = np.asarray(controller.node_kind), np.asarray(controller.node_ref)
    n_nodes = len(kind)
    counts = {SENSOR: body.n_readings, ACTUATOR: body.shape.n_voxels}
    if len(ref) != n_nodes or not np.isin(kind, (SENSOR, HIDDEN, ACTUATOR, RELAY)).all():
        raise bad(field, "a graph controller", "node kinds and references differ in length "
                  "or hold an unknown kind")
    for code, count in counts.items():
        refs = ref[kind == code]
        if refs.size and not ((refs >= 0) & (refs < count)).all():
            what = "readings" if code == SENSOR else "voxels"
            raise bad(field, f"a graph controller referring to {what} up to {int(refs.max())}",
                      f"its robot's body has {count} {what}")
    edges = [np.asarray(getattr(controller, name)) for name in ("src", "dst", "weight", "bias")]
    if len({len(e) for e in edges}) != 1 or any(
            e.size and not ((e >= 0) & (e < n_nodes)).all() for e in edges[:2]):
        raise bad(field, "a graph controller", f"its edges must join its {n_nodes} nodes")
