"""With ``NUMBA_DISABLE_JIT=1`` every kernel runs as Python, so a researcher can step into the
physics with a debugger (docs/architecture.md, "Debugging a kernel"): an episode of each shape
runs, in the batch (groups of robots in lanes and robots alone) and in the stepper, and gives
the compiled kernels' numbers bit for bit."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

# Both shapes, two of each (a group in lanes) and one more worm alone on its own terrain; an
# evolved graph controller each (sensors, hidden nodes), sensor noise on, hilly ground
# (contacts once landed); 40 control steps, every step recorded.
EPISODES = '''
import sys
import numpy as np
from somite.brain.genome import Genome
from somite.evolution.operators import OperatorConfig, initial_genome, mutate
from somite.brain.compile import compile_genome
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.terrain import parse_terrain
from somite.tasks.locomotion import simulate_batch
from somite.tasks.stepper import Episode


def evolved(shape, seed):
    grow = OperatorConfig(p_mutate_edge=0.2, p_add_edge=0.4, p_remove_edge=0.0, p_add_node=0.4,
                          p_remove_node=0.0)
    rng = np.random.default_rng(seed)
    genome = initial_genome(Body.build(shape), rng)
    for _ in range(20):
        genome, _ = mutate(genome, rng, grow)
    return genome


genomes = [evolved(shape, seed) for shape, seed in
           (("worm", 1), ("worm", 2), ("biped", 3), ("biped", 4), ("worm", 5))]
config = SimConfig(duration=40 / 60)
hilly = parse_terrain("hilly-1-10-42")
terrains = [hilly] * 4 + [parse_terrain("steppy-1-10-7")]
_, trace = simulate_batch([g.body for g in genomes], terrains,
                          [compile_genome(g) for g in genomes], config, seeds=[3, 4, 5, 6, 7],
                          record=True)
episode = Episode(genomes[1:4], hilly, config, seeds=[9, 10, 11], record=True)
while not episode.done:
    episode.step()
arrays = {f"batch.{name}": np.asarray(value) for name, value in trace._asdict().items()}
arrays.update({f"stepper.{name}": np.asarray(value)
               for name, value in episode.trace._asdict().items()})
np.savez(sys.argv[1], **arrays)
'''


def _episodes(tmp_path: Path, name: str, **env) -> dict:
    script = tmp_path / "episodes.py"
    script.write_text(EPISODES)
    out = tmp_path / f"{name}.npz"
    done = subprocess.run([sys.executable, "-W", "ignore::RuntimeWarning", str(script), str(out)],
                          env={**os.environ, **env}, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    with np.load(out) as saved:
        return dict(saved)


def test_pure_python_episodes_of_each_shape_give_the_compiled_numbers(tmp_path):
    # Numba's numpy error model gives inf/nan where Python would raise; the noise hash wraps
    # around 2**64 in both, numpy warning of it (-W ignore).
    python = _episodes(tmp_path, "python", NUMBA_DISABLE_JIT="1")
    compiled = _episodes(tmp_path, "compiled", NUMBA_DISABLE_JIT="0")
    assert python.keys() == compiled.keys()
    # Every step from step 0; the robots land and move (contacts, actuation, readings).
    assert python["batch.pos"].shape[:2] == (5, 41) and python["stepper.pos"].shape[:2] == (3, 41)
    assert python["batch.contact"].any() and python["stepper.contact"].any()
    for name in compiled:
        # Bit for bit: the same dtype, shape and bytes (nan and -0.0 included).
        same = (python[name].dtype, python[name].shape, python[name].tobytes())
        assert same == (compiled[name].dtype, compiled[name].shape, compiled[name].tobytes()), name
