"""The batched episode on an NVIDIA GPU: one CUDA thread per robot, the CPU's episode code.

The kernel runs :func:`~somite.tasks.episode.episode`, the very function that each CPU thread
runs for its robot, compiled as a CUDA device function by :func:`somite._jit.device_twin`
(with everything it calls), so the two backends cannot drift apart. What a CPU thread
allocates for its robot comes here from per-batch device arrays (:class:`Work`).

The batch's inputs and work arrays are stored robot-fastest in GPU memory
(:func:`robot_major`): the kernels still index ``a[b, ...]``, but neighbouring threads then
read neighbouring addresses, which the GPU serves in one memory transaction instead of 32.

Import this module only when :func:`~somite.tasks.backends.cuda_unavailable` says None.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import config, cuda

from .._jit import device_twin
from ..sim.physics import N_CONTACT_COLUMNS, N_ROPE_COLUMNS, N_SPRING_COLUMNS, N_WELD_COLUMNS
from ..sim.robot import contact_capacity, ground_view, robot_in, scratch_in
from ..sim.sensors import lidar_rays
from .episode import Controllers, Trace, episode

THREADS_PER_BLOCK = 64
"""Robots per thread block: small, since a thread's robot keeps many registers busy."""

TERRAIN_FIELDS = frozenset({"terrain_n", "terrain_x", "terrain_y", "terrain_nx", "terrain_ny"})
"""The fields of :class:`~somite.sim.system.System` indexed by terrain, not by robot: kept in
the host's layout (the others, robot axis first, are stored robot-fastest)."""


class Work(NamedTuple):
    """Per-robot work arrays of a batch (B robots, padded like the system's arrays)."""

    inv_mass: np.ndarray  # (B, P) from robot_in
    inv_inertia: np.ndarray  # (B, P)
    rest: np.ndarray  # (B, S) the Scratch fields, in order
    cos: np.ndarray  # (B, P)
    sin: np.ndarray  # (B, P)
    spring: np.ndarray  # (B, S, N_SPRING_COLUMNS)
    rope: np.ndarray  # (B, Y, N_ROPE_COLUMNS)
    weld: np.ndarray  # (B, W, N_WELD_COLUMNS)
    contacts: np.ndarray  # (B, capacity, N_CONTACT_COLUMNS)
    previous: np.ndarray  # (B, capacity, N_CONTACT_COLUMNS)
    counts: np.ndarray  # (B, 2) int64
    polygon: np.ndarray  # (B, 2, 4, 4)
    clipped: np.ndarray  # (B, 2, 4)
    contact: np.ndarray  # (B, P) bool
    segment: np.ndarray  # (B, P + 1) int64
    body_pos: np.ndarray  # (B, P, 3) the state of episode()
    body_vel: np.ndarray  # (B, P, 3)
    pos: np.ndarray  # (B, P, 2) the voxel corners
    vel: np.ndarray  # (B, P, 2)
    voxels: np.ndarray  # (B, V, 6)
    touch_hist: np.ndarray  # (B, V, touch window)
    vel_hist: np.ndarray  # (B, V, velocity window, 2)
    readings: np.ndarray  # (B, R)
    actuation: np.ndarray  # (B, V)
    h_prev: np.ndarray  # (B, N)
    h_next: np.ndarray  # (B, N)


class _RobotFirst:
    """A contiguous device array of shape (..., B) seen as (B, ...), through the CUDA array
    interface (public; numba's ``cuda.as_cuda_array`` reads it): a view, no copy. It keeps
    the device array alive as long as the view."""

    def __init__(self, device, shape: tuple):
        self.device = device
        interface = dict(device.__cuda_array_interface__)
        strides = interface["strides"] or _c_strides(device.shape, device.dtype.itemsize)
        interface.update(shape=tuple(shape), strides=(strides[-1], *strides[:-1]))
        self.__cuda_array_interface__ = interface


def _c_strides(shape: tuple, itemsize: int) -> tuple:
    """The strides of a C-contiguous array (the interface may give None for them)."""
    strides = [itemsize]
    for n in reversed(shape[1:]):
        strides.insert(0, strides[0] * n)
    return tuple(strides)


def robot_major(host: np.ndarray | None, shape: tuple, dtype=np.float64):
    """A device array of ``shape`` (robot axis first), stored with the robot axis fastest;
    a copy of ``host`` when given, else uninitialised."""
    if host is not None:
        shape, dtype = host.shape, host.dtype
    if len(shape) < 2 or 0 in shape or config.ENABLE_CUDASIM:
        # No layout to choose (one axis, or nothing stored); the simulator runs in host memory,
        # where the layout changes nothing but speed (and its arrays have no CUDA array
        # interface).
        return cuda.to_device(host) if host is not None else cuda.device_array(shape, dtype)
    moved = np.empty(shape[1:] + shape[:1], dtype) if host is None else np.ascontiguousarray(
        np.moveaxis(host, 0, -1))
    return cuda.as_cuda_array(_RobotFirst(cuda.to_device(moved), shape))


def new_work(system, ctrl, params) -> Work:
    n = system.n_points.shape[0]
    p = system.initial_pos.shape[1]
    s = system.spring_ends.shape[1]
    y = system.rope_ends.shape[1]
    w = system.weld_ends.shape[1]
    c = contact_capacity(p, system.pair_ends.shape[1])
    v = system.voxel_corners.shape[1]
    r = system.reading_code.shape[1]
    nodes = max(1, ctrl.node_kind.shape[1])

    def new(*tail, dtype=np.float64):
        return robot_major(None, (n, *tail), dtype)

    return Work(
        new(p), new(p), new(s), new(p), new(p), new(s, N_SPRING_COLUMNS),
        new(y, N_ROPE_COLUMNS), new(w, N_WELD_COLUMNS), new(c, N_CONTACT_COLUMNS),
        new(c, N_CONTACT_COLUMNS), new(2, dtype=np.int64), new(2, 4, 4), new(2, 4),
        new(p, dtype=np.bool_), new(p + 1, dtype=np.int64),
        new(p, 3), new(p, 3), new(p, 2), new(p, 2), new(v, 6), new(v, int(params.touch_window)),
        new(v, int(params.velocity_window), 2), new(r), new(v), new(nodes), new(nodes),
    )


def _upload(batch: tuple, robot_axis: bool = True) -> tuple:
    """A NamedTuple of host arrays as device arrays (same NamedTuple type)."""
    return type(batch)(*(
        robot_major(a, a.shape) if robot_axis and a.ndim > 1 else cuda.to_device(a)
        for a in batch
    ))


_robot_in = device_twin(robot_in)
_scratch_in = device_twin(scratch_in)
_ground_view = device_twin(ground_view)
_episode = device_twin(episode)


@cuda.jit
def _run_batch(system, ctrl, params, noise, seeds, n_steps, trace, work, rays):
    b = cuda.grid(1)
    if b >= seeds.shape[0]:
        return
    n_points = system.n_points[b]
    n_springs = system.n_springs[b]
    n_voxels = system.n_voxels[b]
    n_nodes = ctrl.n_nodes[b]
    robot = _robot_in(system, b, params, work.inv_mass[b, :n_points],
                      work.inv_inertia[b, :n_points])
    scratch = _scratch_in(
        robot, work.rest[b, :n_springs], work.cos[b, :n_points], work.sin[b, :n_points],
        work.spring[b, :n_springs], work.rope[b, :system.n_ropes[b]],
        work.weld[b, :system.n_welds[b]], work.contacts[b], work.previous[b], work.counts[b],
        work.polygon[b], work.clipped[b], work.contact[b, :n_points],
        work.segment[b, :n_points + 1],
    )
    _episode(b, system, ctrl, params, noise, seeds[b], n_steps, trace, robot,
             _ground_view(system, b), scratch, work.body_pos[b, :n_points],
             work.body_vel[b, :n_points], work.pos[b, :n_points], work.vel[b, :n_points],
             work.voxels[b, :n_voxels], work.touch_hist[b, :n_voxels],
             work.vel_hist[b, :n_voxels], work.readings[b, :system.n_readings[b]],
             work.actuation[b, :n_voxels], work.h_prev[b, :n_nodes], work.h_next[b, :n_nodes],
             rays)


def run_batch(system, ctrl: Controllers, params, noise, seeds, n_steps: int,
              trace: Trace) -> None:
    """:func:`somite.tasks.episode.run_batch` on the GPU: fills the host ``trace`` (which must
    not record: its per-step arrays must have 0 rows)."""
    if trace.pos.shape[0]:
        raise ValueError("the cuda backend does not record episodes")
    n = seeds.shape[0]
    if n == 0:
        return
    device_system = type(system)(**{
        name: cuda.to_device(a) if name in TERRAIN_FIELDS else robot_major(a, a.shape)
        for name, a in system._asdict().items()
    })
    # The trace keeps the host's layout: a thread writes a few values of it per control step,
    # and the copies back need no transposing.
    device_trace = _upload(trace, robot_axis=False)
    blocks = (n + THREADS_PER_BLOCK - 1) // THREADS_PER_BLOCK
    _run_batch[blocks, THREADS_PER_BLOCK](
        device_system, _upload(ctrl), params, cuda.to_device(noise), cuda.to_device(seeds),
        n_steps, device_trace, new_work(system, ctrl, params), cuda.to_device(lidar_rays(params)),
    )
    for host, device in zip(trace, device_trace):
        device.copy_to_host(host)
