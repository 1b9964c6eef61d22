"""Compile the kernels into Numba's on-disk cache before the suite runs (``make test``).

On a fresh clone every kernel compiles cold, minutes each, and pytest's workers would each
compile the same ones at once; two of these processes side by side compile them once, one
set a core, and every test then loads them from the cache. Run as
``python tests/compile_kernels.py evolve|simulate``.
"""

import sys
import tempfile
import warnings
from pathlib import Path

from somite.cli import main
from somite.sim.body import Body
from somite.sim.config import preset
from somite.sim.terrain import hilly

warnings.simplefilter("ignore", RuntimeWarning)  # uint64 hashing wraps, as it does compiled
if sys.argv[1:] == ["evolve"]:
    with tempfile.TemporaryDirectory() as folder:
        code = main(["evolve", "--shape", "worm", "--population", "6", "--duration", "0.5",
                     "--generations", "1", "--seed", "3", "--quiet",
                     "--out", str(Path(folder) / "run")])
elif sys.argv[1:] == ["simulate"]:
    import numpy as np

    from somite.bench import random_graph
    from somite.tasks.stepper import Episode

    code = main(["simulate", "--shape", "worm", "--terrain", "hilly-1-10-0", "--controller",
                 "sine:freq=1,amp=1,phase=-1", "--duration", "0.5", "--json"])
    bodies = [Body.build("worm"), Body.build("biped")]
    rng = np.random.default_rng(1)
    graphs = [random_graph(body, 40, rng) for body in bodies]
    for name in ("paper", "original-code"):
        Episode(graphs, [hilly(1.0, 10.0, 7), hilly(1.0, 10.0, 8)], preset(name, duration=0.1),
                [11, 12], bodies=bodies).run()
else:
    sys.exit("usage: python tests/compile_kernels.py evolve|simulate")
sys.exit(code)
