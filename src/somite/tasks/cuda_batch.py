"""The batched episode on an NVIDIA GPU: one CUDA thread per robot, the CPU's episode code.

The kernel runs :func:`~somite.tasks.episode.episode`, the very function that each CPU thread
runs for its robot, compiled as a CUDA device function by :func:`somite._jit.device_twin`
(with everything it calls), so the two backends cannot drift apart. What a CPU thread
allocates for its robot comes here from per-batch device arrays: the
:class:`~somite.tasks.work.Work` of :func:`~somite.tasks.work.new_work`, robot ``b``'s
row sliced by :func:`~somite.tasks.episode.work_row`.

The batch's inputs and work arrays are stored robot-fastest in GPU memory
(:func:`robot_major`): the kernels still index ``a[b, ...]``, but neighbouring threads then
read neighbouring addresses, which the GPU serves in one memory transaction instead of 32.

Import this module only when :func:`~somite.tasks.backends.cuda_unavailable` says None.
"""

from __future__ import annotations

import numpy as np
from numba import config, cuda

from .._jit import device_twin
from ..sim.sensors import lidar_rays
from .episode import Batch, Controllers, Trace, episode, robot_state, work_row
from .work import new_work

THREADS_PER_BLOCK = 64
"""Robots per thread block: small, since a thread's robot keeps many registers busy."""

TERRAIN_FIELDS = frozenset({"terrain_n", "terrain_x", "terrain_y", "terrain_nx", "terrain_ny"})
"""The fields of :class:`~somite.sim.system.System` indexed by terrain, not by robot: kept in
the host's layout (the others, robot axis first, are stored robot-fastest)."""


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


def _upload(batch: tuple, robot_axis: bool = True) -> tuple:
    """A NamedTuple of host arrays as device arrays (same NamedTuple type)."""
    return type(batch)(*(
        robot_major(a, a.shape) if robot_axis and a.ndim > 1 else cuda.to_device(a)
        for a in batch
    ))


_robot_state = device_twin(robot_state)
_work_row = device_twin(work_row)
_episode = device_twin(episode)


@cuda.jit
def _run_batch(batch):
    b = cuda.grid(1)
    if b >= batch.seeds.shape[0]:
        return
    system, params = batch.system, batch.params
    state = _robot_state(system, b, params,
                         _work_row(batch.work, b, system, batch.ctrl, params), batch.rays)
    _episode(b, batch, state)


def _robot_major_empty(shape: tuple, dtype):
    return robot_major(None, shape, dtype)


def run_batch(system, ctrl: Controllers, params, noise, seeds, n_steps: int,
              trace: Trace) -> None:
    """:func:`somite.tasks.lanes.run_batch` on the GPU: fills the host ``trace`` (which must
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
    _run_batch[blocks, THREADS_PER_BLOCK](Batch(
        device_system, _upload(ctrl), params, cuda.to_device(noise), cuda.to_device(seeds),
        n_steps, device_trace, new_work(system, ctrl, params, _robot_major_empty),
        cuda.to_device(lidar_rays(params)),
    ))
    for host, device in zip(trace, device_trace):
        device.copy_to_host(host)
