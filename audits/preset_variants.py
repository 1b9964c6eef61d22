"""Which difference matters: parent re-evaluation or the original code's sensors and neurons.

Four EA variants (``paper``, ``paper`` + parent re-evaluation, ``original-code``,
``original-code`` without parent re-evaluation), worm and biped, seeds 0-4, 200 generations,
population 48, otherwise the paper's settings. Each run's final best is re-run on 30 hilly
terrains that no run trained on (training seeds are in [0, 10000), the fixed validation
terrains are 10000..10009; these are 20000..20029), with the simulator preset the run used.

    python audits/preset_variants.py run      # evolve every missing run (restartable)
    python audits/preset_variants.py analyse  # JSON on stdout (and audits/preset-variants.json)
    python audits/preset_variants.py table    # the markdown tables of that JSON

Run directories live in runs/preset-variants (ignored by git; $PRESET_VARIANTS_RUNS
overrides); a finished run is skipped, an interrupted one resumed from its checkpoint.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from somite.analysis.stats import load_run, mann_whitney, pairwise_mann_whitney, to_json

RUNS = Path(os.environ.get("PRESET_VARIANTS_RUNS", "runs/preset-variants"))
HERE = Path(__file__).resolve().parent
SHAPES = ("worm", "biped")
SEEDS = range(5)
GENERATIONS = 200
POPULATION = 48
UNSEEN = [20000 + i for i in range(30)]
BUDGET = POPULATION * (GENERATIONS + 1)
"""Simulations of a run without parent re-evaluation (the first population and 200 broods)."""
VARIANTS = {
    # Explicit: the default of reevaluate_parents changed to True after these runs.
    "paper": {"preset": "paper", "reevaluate_parents": False},
    "paper+reeval": {"preset": "paper", "reevaluate_parents": True},
    "original-code": {"preset": "original-code"},
    "original-code-noreeval": {"preset": "original-code", "reevaluate_parents": False},
}


def _toml(options: dict) -> str:
    def value(v):
        return ("true" if v else "false") if isinstance(v, bool) else json.dumps(v)
    return "".join(f"{k} = {value(v)}\n" for k, v in options.items())


def run_dir(variant: str, shape: str, seed: int) -> Path:
    return RUNS / f"{variant}-{shape}-{seed}"


def finished(path: Path) -> bool:
    checkpoint = path / "checkpoint.json"
    if not checkpoint.is_file():
        return False
    try:
        return json.loads(checkpoint.read_text())["generation"] >= GENERATIONS
    except (ValueError, KeyError):
        return False


def run_all() -> None:
    somite = str(Path(sys.executable).parent / "somite")
    RUNS.mkdir(parents=True, exist_ok=True)
    # Seeds outermost, so that whatever has finished covers every variant evenly.
    for seed in SEEDS:
        for shape in SHAPES:
            for variant, options in VARIANTS.items():
                path = run_dir(variant, shape, seed)
                if finished(path):
                    continue
                config = RUNS / f"{variant}.toml"
                config.write_text(_toml({**options, "population": POPULATION}))
                command = [somite, "evolve", "--shape", shape, "--seed", str(seed),
                           "--generations", str(GENERATIONS), "--out", str(path), "--quiet"]
                if (path / "checkpoint.json").is_file():
                    command.append("--resume")
                else:
                    command += ["--config", str(config), "--force"]
                print(" ".join(command), flush=True)
                subprocess.run(command, check=True)


def unseen_velocities(path: Path, generation: int = GENERATIONS) -> dict:
    """v_x of the run's best at ``generation`` (from bests.jsonl) on the unseen and on the 10
    fixed validation terrains, with the simulator preset (and episode length) the run trained
    with; cached in the run directory."""
    cache = path / ("unseen.json" if generation == GENERATIONS else f"unseen-{generation}.json")
    if cache.is_file():
        return json.loads(cache.read_text())
    from somite._io import write_atomic
    from somite.brain.genome import Genome
    from somite.sim.config import preset
    from somite.sim.terrain import hilly
    from somite.tasks.validation import evaluate, validation_terrains

    config = json.loads((path / "config.json").read_text())
    sim = preset(config["preset"], duration=float(config["duration"]),
                 transient=float(config["transient"]))
    with open(path / "bests.jsonl", encoding="utf-8") as lines:
        entry = next(e for e in map(json.loads, lines) if e["generation"] == generation)
    best = Genome.from_dict(entry["genome"])
    unseen = evaluate([best], [hilly(1.0, 10.0, s) for s in UNSEEN], sim)[0]
    validation = evaluate([best], validation_terrains(10), sim)[0]
    data = {"generation": generation, "unseen": [float(v) for v in unseen],
            "validation": [float(v) for v in validation]}
    write_atomic(cache, json.dumps(data) + "\n")
    return data


def equal_budget_generation(path: Path, evaluations: int) -> int:
    """The first generation at which the run had spent ``evaluations`` simulations."""
    log = load_run(path).log
    return int(log["generation"][np.argmax(log["evaluations"] >= evaluations)])


def _summary(values: list[float]) -> dict:
    x = np.asarray(values, dtype=np.float64)
    return {
        "n": int(len(x)),
        "mean": float(np.mean(x)) if len(x) else math.nan,
        "median": float(np.median(x)) if len(x) else math.nan,
        "sd": float(np.std(x, ddof=1)) if len(x) > 1 else math.nan,
    }


def _tests(samples: dict[str, list[float]]) -> list[dict]:
    return [{"a": t.a, "b": t.b, "n_a": t.n_a, "n_b": t.n_b, "u": t.u, "p": t.p}
            for t in pairwise_mann_whitney(samples)]


def analyse() -> dict:
    """Per shape and variant: the logged (lucky) final best and its unseen-terrain mean over
    seeds, the pairwise tests, and the two factors (pooled 10 runs against 10)."""
    report = {
        "commit_at_analysis": subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                                 capture_output=True, text=True).stdout.strip(),
        "generations": GENERATIONS, "population": POPULATION, "seeds": list(SEEDS),
        "unseen_terrains": f"hilly-1-10-{UNSEEN[0]}..{UNSEEN[-1]}",
        "variants": VARIANTS, "shapes": {},
    }
    for shape in SHAPES:
        runs, unseen, logged = {}, {}, {}
        for variant in VARIANTS:
            done = [s for s in SEEDS if finished(run_dir(variant, shape, s))]
            rows = []
            for seed in done:
                path = run_dir(variant, shape, seed)
                log = load_run(path)
                velocities = unseen_velocities(path)
                # Re-evaluating parents doubles the simulations per generation: the best at
                # the generation where the run had spent what a paper run spends in 200.
                at = equal_budget_generation(path, BUDGET)
                budget = unseen_velocities(path, at)["unseen"]
                rows.append({
                    "seed": seed,
                    "logged_best": log.final("best_velocity"),
                    "unseen_mean": float(np.nanmean(velocities["unseen"])),
                    "unseen_nan": int(np.isnan(velocities["unseen"]).sum()),
                    "validation_mean": float(np.nanmean(velocities["validation"])),
                    "equal_budget_generation": at,
                    "equal_budget_unseen_mean": float(np.nanmean(budget)),
                    "evaluations": int(log.final("evaluations")),
                    "best_size": log.final("best_size"),
                })
            runs[variant] = rows
            logged[variant] = [r["logged_best"] for r in rows]
            unseen[variant] = [r["unseen_mean"] for r in rows]
        budget = {v: [r["equal_budget_unseen_mean"] for r in runs[v]] for v in VARIANTS}
        factors = {}
        for name, (with_, without) in FACTORS.items():
            factors[name] = _factor(unseen, with_, without)
        equal = {name: _factor(budget, with_, without) for name, (with_, without)
                 in FACTORS.items()}
        report["shapes"][shape] = {
            "variants": {
                v: {"runs": runs[v], "logged_best": _summary(logged[v]),
                    "unseen": _summary(unseen[v]),
                    "validation": _summary([r["validation_mean"] for r in runs[v]]),
                    "evaluations": _summary([r["evaluations"] for r in runs[v]]),
                    "equal_budget_unseen": _summary(budget[v])}
                for v in VARIANTS
            },
            "tests_unseen": _tests(unseen),
            "tests_equal_budget_unseen": _tests(budget),
            "factors_equal_budget_unseen": equal,
            "tests_logged": _tests(logged),
            "factors_unseen": factors,
        }
    return report


def _factor(samples: dict[str, list[float]], with_: tuple, without: tuple) -> dict:
    a = [v for k in with_ for v in samples[k]]
    b = [v for k in without for v in samples[k]]
    u, p = mann_whitney(a, b)
    return {"with": with_, "without": without, "with_unseen": _summary(a),
            "without_unseen": _summary(b), "u": u, "p": p}


FACTORS = {
    "parent re-evaluation": (("paper+reeval", "original-code"),
                             ("paper", "original-code-noreeval")),
    "original-code differences": (("original-code", "original-code-noreeval"),
                                  ("paper", "paper+reeval")),
}
"""The 2x2 design read as two factors, each pooled over the other's two levels."""


def markdown(report: dict) -> str:
    """The tables of audits/preset-variants.md from :func:`analyse`'s report."""
    def cell(stats: dict) -> str:
        return " / ".join(_p(stats[k], 2) for k in ("mean", "median", "sd"))

    lines = []
    for shape, data in report["shapes"].items():
        lines += [f"**{shape}**", "",
                  "| variant | runs | evaluations | logged best: mean / median / sd "
                  "| 30 unseen terrains: mean / median / sd | per seed (unseen) "
                  f"| at {BUDGET} evaluations: generation, unseen mean / median / sd |",
                  "|---|---|---|---|---|---|---|"]
        for name, v in data["variants"].items():
            seeds = ", ".join(f"{r['unseen_mean']:.2f}" for r in v["runs"])
            at = v["runs"][0]["equal_budget_generation"] if v["runs"] else "-"
            lines.append(f"| `{name}` | {v['unseen']['n']} | {v['evaluations']['mean']:.0f} "
                         f"| {cell(v['logged_best'])} | {cell(v['unseen'])} | {seeds} "
                         f"| {at}: {cell(v['equal_budget_unseen'])} |"
                         if v["runs"] else f"| `{name}` | 0 | - | - | - | - | - |")
        lines += ["", "| pair (unseen) | p | pair (logged) | p |", "|---|---|---|---|"]
        for t, g in zip(data["tests_unseen"], data["tests_logged"]):
            lines.append(f"| `{t['a']}` vs `{t['b']}` | {_p(t['p'])} "
                         f"| `{g['a']}` vs `{g['b']}` | {_p(g['p'])} |")
        lines += ["", "| factor (unseen means, 10 runs vs 10) | with | without | p "
                  f"| at {BUDGET} evaluations: with | without | p |",
                  "|---|---|---|---|---|---|---|"]
        for name, f in data["factors_unseen"].items():
            e = data["factors_equal_budget_unseen"][name]
            lines.append(f"| {name} | {_p(f['with_unseen']['mean'], 2)} "
                         f"| {_p(f['without_unseen']['mean'], 2)} | {_p(f['p'])} "
                         f"| {_p(e['with_unseen']['mean'], 2)} "
                         f"| {_p(e['without_unseen']['mean'], 2)} | {_p(e['p'])} |")
        lines.append("")
    return "\n".join(lines)


def _p(value, digits: int = 3) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


if __name__ == "__main__":
    if sys.argv[1:] == ["run"]:
        run_all()
    elif sys.argv[1:] == ["analyse"]:
        text = to_json(analyse())
        (HERE / "preset-variants.json").write_text(text)
        print(text, end="")
    elif sys.argv[1:] == ["table"]:
        print(markdown(json.loads((HERE / "preset-variants.json").read_text())))
    else:
        sys.exit(f"usage: {sys.argv[0]} run|analyse|table")
