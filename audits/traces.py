"""Physics 1 bit for bit across commits: every trace field of a fixed set of robots, in this
tree and in an earlier commit's (a worktree, as ``benchmarks/versus.py`` makes it).

The robots: worms and bipeds (a group of eight of each, so the lanes run, and one of each
alone), graph, sine, table and zero controllers, on hilly terrains, under the ``paper`` preset,
``original-code`` (the authors' voxel-frame lidar, java-random noise, sigmoid hidden nodes) and
``paper`` without noise; 3 s episodes, recorded (all ten fields). Then ``somite.Episode``
stepped with random actuations over control steps 2-61 and the controllers' own after.
Each tree prints a SHA-256 of every field of every run; the two must be equal.

    python audits/traces.py [--base d543c42]       # compare this tree with the commit's
    python audits/traces.py --print                 # this tree's digests only
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from versus import tree  # noqa: E402  (the commit's worktree, as versus.py makes it)


def digests() -> dict:
    """{run: {field: sha256}} of this interpreter's somite."""
    import numpy as np

    from somite.bench import random_graph
    from somite.brain.controllers import Sine, Table, Zero
    from somite.sim.body import Body
    from somite.sim.config import preset
    from somite.sim.terrain import hilly
    from somite.tasks.locomotion import simulate_batch
    from somite.tasks.stepper import Episode

    rng = np.random.default_rng(68)
    bodies, controllers = [], []
    for shape in ("worm", "biped"):
        body = Body.build(shape)
        v = body.shape.n_voxels
        kinds = [random_graph(body, 200, rng) for _ in range(4)]
        kinds += [Sine(1.5, 1.0, -1.0), Sine(3.0, 0.7, 0.5),
                  Table(rng.uniform(-1.0, 1.0, (37, v))), Zero()]
        kinds.append(random_graph(body, 120, rng))  # the ninth: a group of one
        bodies += [body] * len(kinds)
        controllers += kinds
    terrains = [hilly(1.0, 10.0, 100 + b) for b in range(len(bodies))]
    seeds = list(range(500, 500 + len(bodies)))
    configs = {"paper": preset("paper", duration=3.0),
               "original-code": preset("original-code", duration=3.0),
               "paper-quiet": preset("paper", duration=3.0, noise_sigma=0.0)}
    out = {}

    def add(run, trace):
        out[run] = {f: hashlib.sha256(np.ascontiguousarray(getattr(trace, f)).tobytes())
                    .hexdigest()[:16] for f in trace._fields}

    for name, config in configs.items():
        _, trace = simulate_batch(bodies, terrains, controllers, config, seeds, record=True)
        add(name, trace)
    # The stepper: the same robots, random actuation over steps 2 .. 61 (whether the first
    # call's is put in force is the env's semantics, not the physics).
    config = configs["paper"]
    stepped = Episode(controllers, terrains, config, seeds=seeds, record=True, bodies=bodies)
    actions = np.random.default_rng(7).uniform(-1.0, 1.0, (60, len(bodies), stepped.n_voxels))
    stepped.step()
    for a in actions:
        stepped.step(a)
    stepped.run()
    add("stepper", stepped.trace)
    return out


def in_tree(src: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(src)}
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run([sys.executable, __file__, "--print"], env=env, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="d543c42")
    parser.add_argument("--print", action="store_true", help="this tree's digests, as JSON")
    args = parser.parse_args()
    if args.print:
        print(json.dumps(digests()))
        return
    before = in_tree(tree(args.base) / "src")
    now = in_tree(ROOT / "src")
    differ = [f"{run}.{field}" for run in before for field in before[run]
              if now.get(run, {}).get(field) != before[run][field]]
    print(json.dumps({"base": args.base, "runs": list(before), "fields": len(
        next(iter(before.values()))), "differ": differ, "same": not differ}, indent=1))
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
