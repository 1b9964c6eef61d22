"""Compile the CUDA episode kernel to PTX without a GPU: typing, lowering and NVVM, as on a card.

The simulator (``NUMBA_ENABLE_CUDASIM=1``) runs the kernel as Python, so it cannot tell
whether numba-cuda can compile it; this can, on a machine with no GPU. It needs numba-cuda and
NVIDIA's NVVM and NVRTC wheels (``pip install "cuda-toolkit[nvvm,nvrtc,cudart]==13.*"``, about
150 MB, not part of any extra), and borrows a device's compute capability, which numba-cuda
otherwise reads from the driver. Prints the size of the PTX and its time; JSON.

Usage: NUMBA_FORCE_CUDA_CC=9.0 python benchmarks/cuda_compile.py
"""

from __future__ import annotations

import json
import time
import types as pytypes

import numba.cuda.dispatcher
import numpy as np
from numba import cuda, typeof, types

from somite.bench import random_graph
from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.sensors import lidar_rays, noise_table
from somite.sim.system import compile_system
from somite.sim.terrain import hilly
from somite.tasks import cuda_batch
from somite.tasks.episode import new_trace
from somite.tasks.locomotion import compile_controllers

CC = (9, 0)


def robot_major(batch, first_plain=None):
    """The kernel's type of a NamedTuple uploaded by cuda_batch: a robot-axis array is
    Fortran-ordered in 2 dimensions, strided ('A') in more; the fields from ``first_plain`` on
    stay as they are."""
    fields = typeof(batch).types
    stop = len(fields) if first_plain is None else batch._fields.index(first_plain)
    return types.NamedTuple([t.copy(layout="F" if t.ndim == 2 else "A")
                             if i < stop and t.ndim > 1 else t
                             for i, t in enumerate(fields)], type(batch))


def main() -> dict:
    numba.cuda.dispatcher.get_current_device = lambda: pytypes.SimpleNamespace(
        compute_capability=CC)
    rng = np.random.default_rng(0)
    body = Body.build("worm")
    config = SimConfig(duration=1.0)
    system = compile_system([body] * 2, [hilly(1.0, 10.0, 0), hilly(1.0, 10.0, 1)])
    ctrl = compile_controllers([random_graph(body, 60, rng) for _ in range(2)], [12, 12])
    params = pack_params(config)
    dims = {"force": 3, "dpos": 3, "dvel": 3, "hits": 3, "body_pos": 3, "body_vel": 3,
            "pos": 3, "vel": 3, "voxels": 3, "touch_hist": 3, "vel_hist": 4}
    kinds = {"contact": types.boolean, "segment": types.int64}
    work = types.NamedTuple([types.Array(kinds.get(f, types.float64), dims.get(f, 2),
                                         "A" if f in dims else "F")
                             for f in cuda_batch.Work._fields], cuda_batch.Work)
    argtypes = (robot_major(system, "terrain_of"), robot_major(ctrl), typeof(params),
                typeof(noise_table(config)), typeof(np.zeros(2, np.uint64)), types.int64,
                typeof(new_trace(2, config.n_steps, system, False)), work,
                typeof(lidar_rays(params)))
    start = time.perf_counter()
    ptx, _ = cuda.compile_ptx(cuda_batch._run_batch.py_func, argtypes, cc=CC)
    return {"cc": list(CC), "ptx_characters": len(ptx),
            "compile_seconds": round(time.perf_counter() - start, 1)}


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
