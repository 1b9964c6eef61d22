"""Step-by-step check of the paper-sensors driver against somite (noise sigma 0).

For each genome of a ``{"name", "genome"}`` JSONL file (or a run's bests.jsonl lines) and each
terrain: runs ``CL dump`` (SENSORS, HIDDEN from the environment of this script's caller: give
--sensors paper|code and --hidden tanh|sigmoid) and somite's matching preset with noise sigma 0,
and prints per cell the largest reading difference over the first N control steps, the centre's
x difference at 1 s, 2 s, 5 s and the end, and both v_x.

    source $VSR/env.sh    # the driver's build, with classes-main-sensors/ (README beside)
    PYTHONPATH=src python benchmarks/reference/closed-loop/variant-paper-sensors/check_sensors.py \
        GENOMES.jsonl --terrains flat,hilly-1-10-10000 --sensors paper --hidden tanh
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from somite.brain.compile import compile_genome
from somite.brain.genome import Genome
from somite.sim.config import preset
from somite.sim.system import geometry
from somite.sim.terrain import parse_terrain
from somite.tasks.locomotion import simulate_batch

EXPORT = (Path(__file__).resolve().parents[5]
          / "shared/tools/closed-loop-2dvsrsim/export_genomes.py")
"""The driver's export script, in ``shared/`` beside the repository (as transfer.py's)."""


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("genomes")
    p.add_argument("--terrains", default="flat,hilly-1-10-10000")
    p.add_argument("--sensors", default="paper", choices=["paper", "code"])
    p.add_argument("--hidden", default="tanh", choices=["tanh", "sigmoid"])
    p.add_argument("--main", default="classes-main-sensors")
    p.add_argument("--dyn4j", default="classes-dyn4j")
    p.add_argument("--steps", type=int, default=60, help="readings compared over these steps")
    a = p.parse_args()
    vsr = Path(os.environ["VSR"])
    cp = os.pathsep.join(str(vsr / x) for x in (a.main, "classes-hmsr", a.dyn4j, "lib/*"))
    entries = [json.loads(line) for line in open(a.genomes) if line.strip()]
    entries = [{"name": e.get("name") or f"g{e['generation']:05d}", "genome": e["genome"]}
               for e in entries]
    config = preset("paper" if a.sensors == "paper" else "original-code", noise_sigma=0.0,
                    hidden_activation=a.hidden, duration=30.0, transient=5.0)
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "g.jsonl"
        src.write_text("".join(json.dumps(e) + "\n" for e in entries))
        txt = subprocess.run([sys.executable, str(EXPORT), str(src)], capture_output=True,
                             text=True, check=True).stdout
        (Path(tmp) / "g.txt").write_text(txt)
        env = {**os.environ, "SENSORS": a.sensors, "HIDDEN": a.hidden}
        for e in entries:
            genome = Genome.from_dict(e["genome"])
            body = genome.body
            order = sorted(range(body.shape.n_voxels),
                           key=lambda v: (body.shape.voxels[v][1], body.shape.voxels[v][0]))
            cols = [r for v in order for r, rd in enumerate(body.readings) if rd.voxel == v]
            for tname in a.terrains.split(","):
                out = Path(tmp) / "d.csv"
                done = subprocess.run(["java", "-cp", cp, "CL", "dump", str(Path(tmp) / "g.txt"),
                                       e["name"], tname, "0", str(out)], capture_output=True,
                                      text=True, env=env, check=True)
                jvx = float(done.stdout.split("vx=")[1].split()[0])
                j = np.loadtxt(out, delimiter=",")
                nr = body.n_readings
                jread = j[:, 4:4 + nr]
                jx = j[:, 2]
                outs, trace = simulate_batch([body], [parse_terrain(tname)],
                                             [compile_genome(genome)], config, record=True)
                sread = trace.readings[0][:, cols]
                pos = trace.pos[0]
                corners = geometry(body).corners
                sx = pos[:, corners, 0].mean(axis=(1, 2))
                # Java's row k - 1 (control step k, from 1) is somite's row k (row 0: the start)
                per_kind = {}
                for k in ("area", "touch", "velocity", "lidar"):
                    idx = [i for i, c in enumerate(cols) if body.readings[c].kind == k]
                    if idx:
                        per_kind[k] = [float(np.abs(jread[:n, idx] - sread[1:n + 1, idx]).max())
                                       for n in (1, 10, a.steps)]
                dx = {f"{s}s": float(abs(jx[int(s * 60) - 1] - sx[int(s * 60)]))
                      for s in (0.5, 1, 2, 5, 30)}
                print(json.dumps({"name": e["name"], "terrain": tname,
                                  f"max_diff_steps_1_10_{a.steps}": per_kind,
                                  "x_diff": dx, "vsr_vx": jvx,
                                  "somite_vx": float(outs[0].velocity)}), flush=True)


if __name__ == "__main__":
    main()
