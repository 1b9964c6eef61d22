"""A tiny campaign directory built the way ``somite campaign run`` builds one: each task is the
matching ``somite`` command writing its folder, then ``done.json`` (the layout of
:mod:`somite.campaigns.directory`).

Experiments as in the built-in campaigns, at a budget of seconds: rq1, ablation, omega-10 and
omega-0.1 evolve runs; homogeneous and heterogeneous reassemblies with their
re-optimisations; discovery on the rq1 bests and a reassembly along the discovered modules.
Two tasks are left unfinished: ``rq1/worm-s3`` (a run without done.json) and
``ablation/worm-s3`` (no folder at all).
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

from somite.cli import main

SHAPES = ("biped", "worm")
SEEDS = (0, 1, 2)
OMEGA_SEEDS = (0, 1)
EVOLVE = ["--generations", "2", "--population", "4", "--duration", "2", "--validate-every", "1",
          "--quiet"]
SIM = ["--duration", "2"]
REOPTIMIZE = ["--generations", "2", "--population", "4", "--duration", "2", "--validation", "2",
              "--validate-every", "1", "--quiet"]
UNFINISHED = ("rq1/worm-s3", "ablation/worm-s3")
HETERO_TAKES = {
    "biped": "left-leg=DONOR1:left-leg,right-leg=DONOR1:right-leg,torso=DONOR2:front",
    "worm": "back=DONOR1:back,front=DONOR2:torso",
}


class Builder:
    def __init__(self, root: Path) -> None:
        self.root = root
        self.tasks: list[dict] = []

    def task(self, experiment, name, kind, argv, needs=(), options=None, finish=True):
        task_id = f"{experiment}/{name}"
        folder = self.root / task_id
        self.tasks.append({"id": task_id, "experiment": experiment, "kind": kind,
                           "path": task_id, "needs": list(needs), "options": options or {}})
        if argv is not None:
            assert main([*argv, "--out", str(folder)]) == 0, task_id
            if finish:
                done = {"task": task_id, "elapsed_s": 0.0, "robot_control_steps": 0,
                        "finished": datetime.now(UTC).isoformat()}
                (folder / "done.json").write_text(json.dumps(done))
        return task_id

    def path(self, task_id: str, *name: str) -> str:
        return str(self.root.joinpath(task_id, *name))

    def evolve(self, experiment, shape, seed, extra=(), options=None, finish=True, run=True):
        argv = ["evolve", "--shape", shape, "--seed", str(seed), *EVOLVE, *extra]
        return self.task(experiment, f"{shape}-s{seed}", "evolve", argv if run else None,
                         options={"shape": shape, "seed": seed, **(options or {})},
                         finish=finish)

    def reassembly(self, experiment, name, donors, extra=()):
        """A reassemble task and its re-optimisation."""
        start = self.task(experiment, name, "reassemble",
                          ["reassemble", *(self.path(d) for d in donors), *SIM,
                           "--validation", "2", *extra],
                          needs=donors, options={"donors": list(donors)})
        self.task(experiment, f"{name}-reopt", "reoptimize",
                  ["reoptimize", self.path(start, "reassembled.json"), "--donors",
                   *(self.path(d) for d in donors), *REOPTIMIZE],
                  needs=[start, *donors], options={"start": start, "donors": list(donors)})

    def write(self) -> None:
        experiments = {name: {"title": name, "paper": ""} for name in dict.fromkeys(
            t["experiment"] for t in self.tasks)}
        data = {"format": "somite-campaign", "version": 1, "name": "tiny",
                "source": "tests/campaign_fixture.py", "experiments": experiments,
                "tasks": self.tasks}
        (self.root / "campaign.json").write_text(json.dumps(data, indent=1))


def build_campaign(root: Path) -> Path:
    b = Builder(root)
    for shape in SHAPES:
        for seed in SEEDS:
            b.evolve("rq1", shape, seed, options={"omega": 1.0})
            b.evolve("ablation", shape, seed, ["--weights-only"], {"representation": "weights"})
    b.evolve("rq1", "worm", 3, finish=False)
    b.evolve("ablation", "worm", 3, run=False)
    for omega in ("10", "0.1"):
        for shape in SHAPES:
            for seed in OMEGA_SEEDS:
                b.evolve(f"omega-{omega}", shape, seed, ["--omega", omega],
                         {"omega": float(omega)})
    for shape in SHAPES:
        for i in SEEDS:
            j = SEEDS[(i + 1) % len(SEEDS)]
            b.reassembly("rq2-homo", f"{shape}-s{i}+s{j}", [f"rq1/{shape}-s{i}",
                                                             f"rq1/{shape}-s{j}"])
        other = SHAPES[1 - SHAPES.index(shape)]
        for i in OMEGA_SEEDS:
            b.reassembly("rq2-hetero", f"{shape}-s{i}+{other}-s{i}",
                         [f"rq1/{shape}-s{i}", f"rq1/{other}-s{i}"],
                         ["--receiver-shape", shape, "--take", HETERO_TAKES[shape]])
        for omega in ("10", "0.1"):
            for i in OMEGA_SEEDS:
                j = OMEGA_SEEDS[(i + 1) % len(OMEGA_SEEDS)]
                b.reassembly("omega-reassembly", f"omega-{omega}-{shape}-s{i}+s{j}",
                             [f"omega-{omega}/{shape}-s{i}", f"omega-{omega}/{shape}-s{j}"])
    for shape in SHAPES:
        for seed in SEEDS:
            genome = f"rq1/{shape}-s{seed}"
            b.task("rq3-discovery", f"{shape}-s{seed}", "discover",
                   ["discover", b.path(genome)], needs=[genome],
                   options={"genome": genome, "b_min": 2, "b_max": 5})
        partition = b.path(f"rq3-discovery/{shape}-s0", "partition.json")
        b.reassembly("rq3-reassembly", f"{shape}-s0+s1", [f"rq1/{shape}-s0", f"rq1/{shape}-s1"],
                     ["--partition", partition])
    b.write()
    return root
