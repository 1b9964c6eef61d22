"""How fast somite's evolved robots are in the paper's simulator (2D-VSR-Sim 1.9.2 on dyn4j 3.3.0).

The transfer check: for each run directory (``somite evolve ... --out DIR``) it takes the best
genome of generations 0, G, 2G, ... (``--every G``) and of the last generation from the run's
``bests.jsonl``, re-runs each on a fixed set of terrains (``--terrains``) in 2D-VSR-Sim through
the Java driver of ``shared/tools/closed-loop-2dvsrsim/`` (``CL genomes``: the authors' graph
controller with the authors' code's sensors, 30 s episodes, v_x over [5 s, 30 s]; genomes
converted by its ``export_genomes.py``) and in somite, twice: on the driver's sensors and with
the run's own. Both sides use the driver's episode: 30 s, v_x from 5 s on, whatever the run's
own ``duration``, and the run's sensor noise sigma (0.01 in both presets).

The driver has one set of sensors, the authors' code's (somite's ``original-code`` preset:
voxel frames, windows, its lidar angles, its noise), and runs hidden nodes as the run did
(``HIDDEN``: sigmoid for ``original-code``, tanh for ``paper``). So the like-for-like comparison,
the one that measures the physics, is somite on those same sensors (the ``original-code``
sensors with the run's hidden activation) against 2D-VSR-Sim. A ``paper`` run was evolved on
other sensors (world frames, no windows): what it loses when its controller reads the code's
sensors is a second number, measured in somite alone. It prints, as JSON:

- per run and sampled generation: ``somite_vx`` (the driver's sensors), ``somite_own_vx`` (the
  run's own preset; the same number for an ``original-code`` run) and ``vsr_vx``, each the mean
  v_x [m/s] over the terrains (NaN, ``null``, when any terrain is); ``ratio`` =
  ``vsr_vx / somite_vx``, the physics; ``overall_ratio`` = ``vsr_vx / somite_own_vx``, what
  the run keeps of its own speed in the paper's simulator; the logged ``training_velocity``
  and the per-terrain cells;
- per run: ``median_ratio`` and ``median_overall_ratio``, the medians of the sampled
  generations' ratios from ``--from`` on (ratios that are not finite left out and counted);
  ``preset_mismatch`` when its own sensors are not the driver's;
- ``shapes``: per shape, the median of the runs' median ratios, of both kinds.

``--sensors own`` drives each run on its own sensors instead, through the variant of the
driver in ``benchmarks/reference/closed-loop/variant-paper-sensors/`` (built into the build's
``classes-main-sensors/``; its README says how): ``SENSORS=paper`` for a ``paper`` run (world
frames, no windows, the paper's lidar angles), ``SENSORS=code`` for an ``original-code`` run
(the shared driver's sensors); a run whose sensor settings are neither preset's exactly is
refused. Then somite runs each best on the run's own preset only: ``somite_vx`` =
``somite_own_vx``, ``ratio`` = ``overall_ratio``, the physics on the sensors the run was
evolved on, and ``preset_mismatch`` is false. Only the noise stream still differs (the driver
draws ``java.util.Random(0)``, a ``paper`` run its own): with noise sigma 0 the two read the same
numbers. Each run's entry names the driver's ``SENSORS`` (``driver_sensors``), the ``driver``
entry the option (``sensors``: ``original-code`` for ``code``, else ``own``), the ``SENSORS``
used (``sensors_read``) and the driver's folder (``main``).

``episode_mismatch`` flags a run evolved on episodes other than 30 s from 5 s. Bodies other than
the worm and the biped with the paper's sensors are refused: the driver cannot build them.

    python benchmarks/transfer.py RUN [RUN ...] [--every 50] [--from 50]
                                  [--terrains flat,hilly-1-10-10000,...|validation]
                                  [--vsr PATH] [--dyn4j classes-dyn4j] [--export PATH]
                                  [--threads 2] [--seed 0] [--sensors code|own]

``--vsr`` (default: env ``VSR``) is a build of the driver (``build.sh``: classes-main/CL.class
beside classes-hmsr/, classes-dyn4j/ and lib/); ``--dyn4j`` names the folder of that build that
holds dyn4j's classes, so that a variant of the engine built beside them runs instead:
``classes-dyn4j-noccd`` is dyn4j with its continuous collision detection off
(``benchmarks/reference/closed-loop/README.md`` says how to build it and why it matters: in
2D-VSR-Sim that detection misfires against the terrain and throws blocks back);
``--export`` the export script (default
``../shared/tools/closed-loop-2dvsrsim/export_genomes.py`` from the repository root).
``--campaign DIR`` (the runs being tasks of the campaign in DIR) also writes each run's last
sampled generation into ``DIR/transfer.csv``, the file the transfer section of ``somite report``
reads (``task,engine,sensors,generation,somite_vx,vsr_vx,ratio,somite_own_vx,overall_ratio``;
engine ``noccd`` when ``--dyn4j`` names the build without continuous collision detection, else
``stock``; sensors ``code`` or ``own``, as ``--sensors``): rows of other runs, engines or
sensors are kept, so running it once per engine and sensors fills the table. A ratio of speeds
near zero is noise: look at the medians, and at ``somite_vx`` beside it.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from somite._io import parse_json, read_text
from somite.brain.genome import Genome
from somite.errors import SomiteError, bad
from somite.experiments.config import RunConfig, resolve
from somite.experiments.history import THINNED
from somite.sim.body import Body
from somite.sim.config import SimConfig, preset
from somite.sim.terrain import Terrain, parse_terrain
from somite.tasks.validation import VALIDATION_COUNT, evaluate, validation_terrains
from somite.tasks.velocity import mean_velocity

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_EXPORT = ROOT.parent / "shared/tools/closed-loop-2dvsrsim/export_genomes.py"
DEFAULT_TERRAINS = ("flat", *(f"hilly-1-10-{10000 + i}" for i in range(5)))
DRIVER_PRESET = "original-code"
"""The sensors 2D-VSR-Sim's driver reads: somite's name for the authors' code's sensors (its
hidden nodes follow the run: :func:`driver_config`)."""
DRIVER_HIDDEN = ("sigmoid", "tanh")
"""The hidden activations CL.java runs (its ``HIDDEN``)."""
DRIVER_DURATION, DRIVER_TRANSIENT = 30.0, 5.0
"""CL.java's episode: ``new Locomotion(30, ...)``, v_x of ``subOutcome(5, 30)``."""
DRIVER_SHAPES = {"worm": "worm-6x2", "biped": "biped-4x3"}
"""The bodies the driver builds (export_genomes.py's names), with the paper's sensors."""
DRIVER_COLUMNS = ("sim", "name", "shape", "terrain", "sigma", "hidden", "vx", "x_first", "x_last",
                  "x_end", "y_end", "seconds")
"""The header CL.java writes in ``genomes`` mode."""
DYN4J = "classes-dyn4j"
"""The build's folder of dyn4j's classes (``--dyn4j``: a variant's folder beside it)."""
SENSOR_OPTIONS = ("code", "own")
"""``--sensors``: the driver on the code's sensors for every run, or on each run's own."""
MAIN = {"code": "classes-main", "own": "classes-main-sensors"}
"""The build's folder of the driver's classes per ``--sensors``: the shared CL.java, or the
variant of ``benchmarks/reference/closed-loop/variant-paper-sensors/`` (``SENSORS=code`` is the
shared driver's behaviour, ``SENSORS=paper`` somite's ``paper`` sensors)."""
DRIVER_SENSORS = {"original-code": "code", "paper": "paper"}
"""somite preset -> the variant driver's ``SENSORS`` that reads that preset's sensors."""
SENSOR_FIELDS = ("lidar_range", "lidar_angles", "lidar_frame", "touch_window", "velocity_window",
                 "velocity_frame", "velocity_max", "voxel_angle")
"""The :class:`SimConfig` fields that decide the readings (the noise stream aside: the driver's
is ``java.util.Random(0)`` whatever the preset, and cannot match somite's ``independent``)."""


def classpath(dyn4j: str, main: str = MAIN["code"]) -> tuple[str, ...]:
    return (main, "classes-hmsr", dyn4j, "lib/*")


@dataclass
class Run:
    """A run directory: its configuration and the sampled generations' best genomes."""

    path: str
    config: RunConfig
    shape: str
    entries: list[dict]
    """``bests.jsonl`` lines of the sampled generations: generation, velocity, genome."""
    last: int


def _generation(entry, path: Path, i: int) -> int:
    g = entry.get("generation") if isinstance(entry, dict) else None
    if isinstance(g, bool) or not isinstance(g, int) or g < 0 or "genome" not in entry:
        raise bad("run", str(path.parent), f"bests.jsonl line {i + 1} has no generation and "
                  "genome")
    return g


def read_bests(path: Path) -> list[dict]:
    """The lines of a run's ``bests.jsonl`` that hold a genome, in generation order (one per
    generation): a line thinned by ``somite campaign pack`` (a best every few generations and
    the last ones kept) holds none, and its generation cannot be sampled."""
    entries, seen = [], set()
    for i, line in enumerate(read_text(path, "run").splitlines()):
        if not line.strip():
            continue
        thinned = THINNED.fullmatch(line)
        entry = None if thinned else parse_json(line, "run", f"{path} line {i + 1}")
        g = int(thinned[1]) if thinned else _generation(entry, path, i)
        if g in seen:
            raise bad("run", str(path.parent), f"bests.jsonl has generation {g} twice")
        seen.add(g)
        if entry is not None:
            entries.append(entry)
    if not entries:
        raise bad("run", str(path.parent), "bests.jsonl is empty (no generation finished)"
                  if not seen else "bests.jsonl has no genome (every line thinned)")
    return sorted(entries, key=lambda e: e["generation"])


def select_generations(generations, every: int) -> list[int]:
    """Generations 0, ``every``, 2 ``every``, ... among ``generations``, and the last one."""
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise bad("every", every, "must be a whole number at least 1")
    present = sorted(set(generations))
    if not present:
        return []
    return sorted({g for g in present if g % every == 0} | {present[-1]})


def driver_shape(genome: Genome, run: str) -> str:
    """``worm`` or ``biped``: the bodies, with the paper's sensors, that CL.java can build."""
    for name in DRIVER_SHAPES:
        if genome.body == Body.build(name):
            return name
    raise bad("run", run, f"body {genome.body.to_dict()['shape']!r} with these sensors: the "
              "2D-VSR-Sim driver builds only the worm and the biped with the paper's sensors")


def load_run(path: str, every: int) -> Run:
    """A run directory, its configuration, and the best genomes of the generations to sample."""
    folder = Path(path)
    if not folder.is_dir():
        raise bad("run", path, "no such run directory" if not folder.exists()
                  else "not a run directory (a file)")
    for name in ("config.json", "bests.jsonl"):
        if not (folder / name).is_file():
            raise bad("run", path, f"not a run directory (no {name}; made by somite evolve --out)")
    saved = parse_json(read_text(folder / "config.json", "run"), "run", str(folder / "config.json"))
    if not isinstance(saved, dict):
        raise bad("run", path, "config.json is not a JSON object")
    try:
        config = resolve(saved)
    except SomiteError as error:
        raise bad("run", path, f"config.json: {error}") from None
    entries = read_bests(folder / "bests.jsonl")
    by_generation = {e["generation"]: e for e in entries}
    chosen = select_generations(list(by_generation), every)
    picked = []
    for g in chosen:
        entry = by_generation[g]
        try:
            genome = Genome.from_dict(entry["genome"])
        except (SomiteError, TypeError, KeyError, AttributeError) as error:
            raise bad("run", path, f"bests.jsonl generation {g}: not a genome ({error})") from None
        if genome.delay_per_voxel:
            # 2D-VSR-Sim delays every edge one step: it would run another controller.
            raise bad("run", path, f"its genomes delay edges by their length (delay_per_voxel="
                      f"{genome.delay_per_voxel:g}, issue 72), which 2D-VSR-Sim cannot run")
        picked.append({"generation": g, "velocity": entry.get("velocity"), "genome": genome,
                       "data": entry["genome"]})
    shapes = {driver_shape(e["genome"], path) for e in picked}
    if len(shapes) != 1:
        raise bad("run", path, f"bests.jsonl mixes bodies {sorted(shapes)}")
    return Run(path, config, shapes.pop(), picked, chosen[-1])


def parse_terrains(text: str) -> list[Terrain]:
    """``--terrains``: comma-separated names, or ``validation`` (the validation set)."""
    if text.strip() == "validation":
        return validation_terrains(VALIDATION_COUNT)
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise bad("terrains", text, "give at least one terrain name")
    terrains = [parse_terrain(name) for name in names]
    canonical = [t.name for t in terrains]
    if len(set(canonical)) != len(canonical):
        raise bad("terrains", text, "names a terrain twice")
    return terrains


def sim_config(config: RunConfig) -> SimConfig:
    """The run's simulator settings (its preset) on the driver's episode."""
    return preset(config.preset, duration=DRIVER_DURATION, transient=DRIVER_TRANSIENT)


def driver_config(config: RunConfig, sensors: str = "code") -> SimConfig:
    """What the driver runs, in somite, on the driver's episode with the run's hidden
    activation: with ``sensors="code"`` the code's sensors (:data:`DRIVER_PRESET`; the two
    presets share their physics), with ``"own"`` the run's own settings (the variant driver
    reads either preset's sensors: :func:`driver_sensors`)."""
    own = sim_config(config)
    if own.hidden_activation not in DRIVER_HIDDEN:
        raise bad("run", config.preset, f"hidden activation {own.hidden_activation!r}: the "
                  f"driver runs only {list(DRIVER_HIDDEN)}")
    if sensors == "own":
        return own
    return preset(DRIVER_PRESET, hidden_activation=own.hidden_activation,
                  duration=DRIVER_DURATION, transient=DRIVER_TRANSIENT)


def driver_sensors(config: SimConfig, run: str = "") -> str:
    """The variant driver's ``SENSORS`` (``code`` or ``paper``) whose readings are those of
    ``config``: its :data:`SENSOR_FIELDS` must be exactly one preset's, else a one-line error."""
    mine = {name: getattr(config, name) for name in SENSOR_FIELDS}
    for name, value in DRIVER_SENSORS.items():
        if mine == {f: getattr(preset(name), f) for f in SENSOR_FIELDS}:
            return value
    raise bad("run", run or config.to_dict(), "--sensors own: its sensor settings are neither "
              "the paper preset's nor the original-code preset's exactly (the driver reads only "
              "those two)")


def sigma_text(sigma: float) -> str:
    """A noise sigma as the driver's argument (it builds ``spinedTouchSighted-f-f-SIGMA``)."""
    return "0" if sigma == 0 else repr(float(sigma))


def parse_driver_csv(text: str) -> dict[tuple[str, str, float], float]:
    """CL.java's ``genomes`` CSV -> v_x by (name, terrain, sigma)."""
    reader = csv.DictReader(io.StringIO(text))
    missing = [c for c in ("name", "terrain", "sigma", "vx") if c not in (reader.fieldnames or [])]
    if missing:
        raise bad("driver_csv", reader.fieldnames, f"lacks the columns {missing}")
    cells = {}
    for i, row in enumerate(reader):
        try:
            key = (row["name"], row["terrain"], float(row["sigma"]))
            cells[key] = float(row["vx"])
        except (TypeError, ValueError):
            raise bad("driver_csv", f"row {i + 2}",
                      "has a sigma or vx that is not a number") from None
    return cells


def ratio(vsr: float, somite: float) -> float:
    """2D-VSR-Sim's v_x over somite's: NaN when either is NaN or somite's is 0."""
    if not (math.isfinite(vsr) and math.isfinite(somite)) or somite == 0:
        return math.nan
    return vsr / somite


def median(values) -> float:
    """The median of the finite ``values`` (NaN when there are none)."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan


def find_java(vsr: str | None, dyn4j: str = DYN4J, sensors: str = "code") -> tuple[str, str]:
    """(java executable, class path) of a driver build with dyn4j's classes from the folder
    ``dyn4j`` of it and the driver's from :data:`MAIN` of ``sensors``, or a one-line error."""
    if not vsr:
        raise bad("vsr", vsr, "give --vsr PATH or set VSR to a build of the 2D-VSR-Sim driver")
    folder = Path(vsr)
    if not folder.is_dir():
        raise bad("vsr", vsr, "no such folder (a build of the 2D-VSR-Sim driver: build.sh)")
    for part in ("classes-main/CL.class", "classes-hmsr/it", f"{DYN4J}/org", "lib"):
        if not (folder / part).exists():
            raise bad("vsr", vsr, f"not a build of the 2D-VSR-Sim driver (no {part}; run "
                      "shared/tools/closed-loop-2dvsrsim/build.sh)")
    if not dyn4j or Path(dyn4j).name != dyn4j or not (folder / dyn4j / "org").is_dir():
        raise bad("dyn4j", dyn4j, f"not a folder of dyn4j's classes in {vsr} (a variant is "
                  "built beside classes-dyn4j: benchmarks/reference/closed-loop/README.md)")
    main = MAIN[sensors]
    if not (folder / main / "CL.class").exists():
        raise bad("sensors", sensors, f"needs the paper-sensors driver in {folder / main} (no "
                  "CL.class; benchmarks/reference/closed-loop/README.md, variant-paper-sensors, "
                  "says how to build it)")
    java = shutil.which("java")
    if java is None:
        raise bad("java", "java", "not found on PATH (a Java 11+ runtime runs the driver)")
    return java, os.pathsep.join(str(folder.resolve() / p) for p in classpath(dyn4j, main))


def check_export(path: str) -> Path:
    script = Path(path)
    if not script.is_file():
        raise bad("export", path, "no such file (export_genomes.py of the 2D-VSR-Sim driver)")
    return script


def _last_line(text: str) -> str:
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return lines[-1].strip()[:300] if lines else "no output"


def run_driver(genomes: dict[str, dict], terrains: list[str], sigmas: list[float], vsr: str,
               export: Path, threads: int, java: tuple[str, str], hidden: str,
               sensors: str | None = None) -> dict:
    """Every genome (name -> genome JSON) x terrain x sigma in 2D-VSR-Sim, its hidden nodes
    ``hidden`` and (the variant driver) its ``SENSORS`` ``sensors``: v_x by (name, terrain,
    sigma). Exports the genomes, runs ``CL genomes`` in a temporary folder."""
    executable, classpath = java
    with tempfile.TemporaryDirectory(prefix="somite-transfer-") as tmp:
        source = Path(tmp) / "genomes.jsonl"
        source.write_text("".join(json.dumps({"name": name, "genome": genome}) + "\n"
                                  for name, genome in genomes.items()))
        done = subprocess.run([sys.executable, str(export), str(source)], capture_output=True,
                              text=True, cwd=tmp)
        if done.returncode != 0:
            raise bad("export", str(export), f"failed: {_last_line(done.stderr)}")
        (Path(tmp) / "genomes.txt").write_text(done.stdout)
        env = {**os.environ, "THREADS": str(threads), "HIDDEN": hidden}
        env.pop("SENSORS", None)
        if sensors is not None:
            env["SENSORS"] = sensors
        command = [executable, "-cp", classpath, "CL", "genomes", "genomes.txt", ",".join(terrains),
                   ",".join(sigma_text(s) for s in sigmas), "out.csv"]
        sys.stderr.write(f"transfer: 2D-VSR-Sim: {len(genomes) * len(terrains) * len(sigmas)} "
                         f"episodes of 30 s, {hidden} hidden nodes, "
                         f"{sensors or 'code'} sensors, on {threads} threads\n")
        done = subprocess.run(command, capture_output=True, text=True, cwd=tmp, env=env)
        out = Path(tmp) / "out.csv"
        if done.returncode != 0 or not out.is_file():
            raise bad("vsr", vsr, f"the driver failed (exit {done.returncode}): "
                      f"{_last_line(done.stderr)}")
        return parse_driver_csv(out.read_text())


def _number(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def compare(runs: list[Run], terrains: list[Terrain], vsr_cells: dict, seed: int,
            start: int, names: dict[str, str], sensors: str = "code") -> dict:
    """The JSON report: somite and 2D-VSR-Sim v_x of every run's sampled generations."""
    report_runs = []
    for run in runs:
        config, own = driver_config(run.config, sensors), sim_config(run.config)
        read = driver_sensors(config, run.path) if sensors == "own" else "code"
        sigma = float(config.noise_sigma)
        genomes = [e["genome"] for e in run.entries]
        somite_vx = evaluate(genomes, terrains, config, seed=seed)
        own_vx = somite_vx if own == config else evaluate(genomes, terrains, own, seed=seed)
        generations = []
        for entry, row, own_row in zip(run.entries, somite_vx, own_vx):
            name = names[_key(entry["data"], config.hidden_activation, read)]
            vsr_row = np.array([vsr_cells.get((name, t.name, sigma), math.nan) for t in terrains])
            s, o, v = (float(mean_velocity(r)) for r in (row, own_row, vsr_row))
            generations.append({
                "generation": entry["generation"],
                "training_velocity": entry["velocity"],
                "somite_vx": _number(s),
                "somite_own_vx": _number(o),
                "vsr_vx": _number(v),
                "ratio": _number(ratio(v, s)),
                "overall_ratio": _number(ratio(v, o)),
                "terrains": {t.name: {"somite": _number(a), "somite_own": _number(c),
                                      "vsr": _number(b)}
                             for t, a, c, b in zip(terrains, row, own_row, vsr_row)},
            })
        counted = [g for g in generations if g["generation"] >= start]
        ratios = [g["ratio"] for g in counted if g["ratio"] is not None]
        overall = [g["overall_ratio"] for g in counted if g["overall_ratio"] is not None]
        episode = {"duration": run.config.duration, "transient": run.config.transient}
        report_runs.append({
            "run": run.path,
            "shape": run.shape,
            "preset": run.config.preset,
            "preset_mismatch": own != config,
            "hidden": config.hidden_activation,
            "driver_sensors": read,
            "episode": episode,
            "episode_mismatch": episode != {"duration": DRIVER_DURATION,
                                            "transient": DRIVER_TRANSIENT},
            "noise_sigma": sigma,
            "last_generation": run.last,
            "generations": generations,
            "median_ratio": _number(median(ratios)),
            "median_overall_ratio": _number(median(overall)),
            "ratios_counted": len(ratios),
            "ratios_left_out": len(counted) - len(ratios),
        })
    shapes = {}
    for shape in sorted({r["shape"] for r in report_runs}):
        mine = [r for r in report_runs if r["shape"] == shape]
        shapes[shape] = {
            "runs": len(mine),
            "median_ratio": _number(median([r["median_ratio"] for r in mine])),
            "median_overall_ratio": _number(median([r["median_overall_ratio"] for r in mine])),
            "runs_preset_mismatch": sum(r["preset_mismatch"] for r in mine)}
    return {"runs": report_runs, "shapes": shapes}


def _key(genome_data: dict, hidden: str, sensors: str = "code") -> str:
    """A genome as the driver runs it: its JSON, the hidden activation and the sensors."""
    return json.dumps([genome_data, hidden, sensors], sort_keys=True)


def transfer(paths: list[str], every: int = 50, start: int = 50,
             terrains: list[Terrain] | None = None, vsr: str | None = None,
             export: str | Path = DEFAULT_EXPORT, threads: int = 2, seed: int = 0,
             dyn4j: str = DYN4J, sensors: str = "code") -> dict:
    """The whole check (see the module docstring); every bad input is a one-line error."""
    if sensors not in SENSOR_OPTIONS:
        raise bad("sensors", sensors, f"use one of {list(SENSOR_OPTIONS)}")
    if isinstance(start, bool) or not isinstance(start, int) or start < 0:
        raise bad("from", start, "must be a whole number, 0 or more")
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise bad("threads", threads, "must be a whole number at least 1")
    terrains = terrains if terrains is not None else [parse_terrain(n) for n in DEFAULT_TERRAINS]
    if not paths:
        raise bad("run", paths, "give at least one run directory")
    runs = [load_run(path, every) for path in paths]
    reads = {run.path: driver_sensors(driver_config(run.config, sensors), run.path)
             if sensors == "own" else "code" for run in runs}
    java = find_java(vsr, dyn4j, sensors)
    script = check_export(str(export))
    names: dict[str, str] = {}  # genome JSON -> driver name; a genome kept for many generations
    groups: dict[tuple[str, str], dict[str, dict]] = {}  # runs once, with its run's hidden
    for run in runs:  # nodes and sensors
        hidden, read = driver_config(run.config, sensors).hidden_activation, reads[run.path]
        for entry in run.entries:
            key = _key(entry["data"], hidden, read)
            if key not in names:
                names[key] = f"genome-{len(names):05d}"
                groups.setdefault((hidden, read), {})[names[key]] = entry["data"]
    sigmas = sorted({float(driver_config(run.config, sensors).noise_sigma) for run in runs})
    cells = {}
    for (hidden, read), genomes in groups.items():
        cells.update(run_driver(genomes, [t.name for t in terrains], sigmas, str(vsr), script,
                                threads, java, hidden, None if sensors == "code" else read))
    report = compare(runs, terrains, cells, seed, start, names, sensors)
    return {
        "terrains": [t.name for t in terrains],
        "every": every,
        "from": start,
        "seed": seed,
        "episode": {"duration": DRIVER_DURATION, "transient": DRIVER_TRANSIENT},
        "driver": {"vsr": str(vsr), "dyn4j": dyn4j, "main": MAIN[sensors],
                   "sensors": DRIVER_PRESET if sensors == "code" else "own",
                   "sensors_read": sorted({read for _, read in groups}),
                   "hidden": sorted({hidden for hidden, _ in groups}),
                   "threads": threads, "episodes": len(cells), "genomes": len(names)},
        **report,
    }


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, as somite's commands
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        sys.exit(2)


CAMPAIGN_COLUMNS = ("task", "engine", "sensors", "generation", "somite_vx", "vsr_vx", "ratio",
                    "somite_own_vx", "overall_ratio")
"""The columns of a campaign's ``transfer.csv`` (somite.report.transfer reads them)."""


def engine_of(dyn4j: str) -> str:
    """``noccd`` for a dyn4j build without continuous collision detection, else ``stock``."""
    return "noccd" if "noccd" in Path(dyn4j).name else "stock"


def campaign_rows(out: dict, campaign: Path, engine: str, sensors: str = "code") -> list[dict]:
    """A row of ``transfer.csv`` per run of ``out`` (:func:`transfer`'s result): its task (the
    run's folder inside ``campaign``), the engine and ``--sensors``, and its last sampled
    generation's velocities and ratios."""
    rows = []
    root = campaign.resolve()
    for run in out["runs"]:
        folder = Path(run["run"]).resolve()
        if root not in folder.parents:
            raise bad("run", run["run"], f"is not a task folder of the campaign {campaign}")
        last = run["generations"][-1]
        rows.append({"task": folder.relative_to(root).as_posix(), "engine": engine,
                     "sensors": sensors, **{k: last.get(k) for k in CAMPAIGN_COLUMNS[3:]}})
    return rows


def write_campaign_csv(campaign: Path, rows: list[dict]) -> Path:
    """Merge ``rows`` into ``campaign/transfer.csv`` (a row of the same task, engine and
    sensors replaced, the others kept, sorted), written atomically. A row of a file written
    before the sensors column is of the code's sensors."""
    from somite._io import write_atomic

    path = campaign / "transfer.csv"
    kept = {}
    if path.is_file():
        for row in csv.DictReader(io.StringIO(read_text(path, "transfer"))):
            row["sensors"] = row.get("sensors") or "code"
            kept[(row["task"], row["engine"], row["sensors"])] = row
    for row in rows:
        kept[(row["task"], row["engine"], row["sensors"])] = {
            k: "" if v is None else v for k, v in row.items()}
    text = io.StringIO()
    writer = csv.DictWriter(text, CAMPAIGN_COLUMNS, lineterminator="\n", extrasaction="ignore")
    writer.writeheader()
    writer.writerows(kept[key] for key in sorted(kept))
    return write_atomic(path, text.getvalue())


def main(argv: list[str] | None = None) -> int:
    parser = _Parser(prog="transfer.py", description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", metavar="RUN", help="run directories")
    parser.add_argument("--every", type=int, default=50, metavar="G",
                        help="sample the best of every G-th generation, and the last (default 50)")
    parser.add_argument("--from", dest="start", type=int, default=50, metavar="G",
                        help="the per-run median counts generations from G on (default 50)")
    parser.add_argument("--terrains", default=",".join(DEFAULT_TERRAINS),
                        help="comma-separated terrain names, or 'validation' (the "
                        f"{VALIDATION_COUNT} validation terrains); default: flat and "
                        "hilly-1-10-10000 ... 10004")
    parser.add_argument("--vsr", default=os.environ.get("VSR"),
                        help="the 2D-VSR-Sim driver's build (default: env VSR)")
    parser.add_argument("--dyn4j", default=DYN4J, metavar="FOLDER",
                        help=f"the build's folder of dyn4j's classes (default {DYN4J}; "
                        "classes-dyn4j-noccd: without continuous collision detection)")
    parser.add_argument("--export", default=str(DEFAULT_EXPORT),
                        help="export_genomes.py (default: ../shared/tools/closed-loop-2dvsrsim/ "
                        "beside the repository)")
    parser.add_argument("--sensors", choices=SENSOR_OPTIONS, default="code",
                        help="code (default): the driver reads the authors' code's sensors for "
                        "every run; own: each run's own preset's (the variant driver in "
                        f"{MAIN['own']}/ of the build)")
    parser.add_argument("--threads", type=int, default=2, help="the driver's THREADS (default 2)")
    parser.add_argument("--seed", type=int, default=0,
                        help="somite's noise seed (paper preset; original-code ignores it)")
    parser.add_argument("--campaign", metavar="DIR",
                        help="also write the runs' last sampled generation into "
                        "DIR/transfer.csv (the report's transfer section); the runs are tasks "
                        "of the campaign in DIR")
    args = parser.parse_args(argv)
    try:
        if args.campaign is not None:  # before the driver runs: its minutes are not lost
            campaign_rows({"runs": [{"run": r, "generations": [{}]} for r in args.runs]},
                          Path(args.campaign), "")
        out = transfer(args.runs, args.every, args.start, parse_terrains(args.terrains),
                       args.vsr, args.export, args.threads, args.seed, args.dyn4j,
                       args.sensors)
        if args.campaign is not None:
            write_campaign_csv(Path(args.campaign), campaign_rows(
                out, Path(args.campaign), engine_of(args.dyn4j), args.sensors))
    except SomiteError as error:
        sys.stderr.write(f"{parser.prog}: error: {error}\n")
        return 2
    json.dump(out, sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
