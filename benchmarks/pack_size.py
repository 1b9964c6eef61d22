"""How big a pack of the whole ``paper-rq1`` campaign will be, from a pack measured here.

``somite campaign pack`` of a campaign directory holding evolve runs (any budget), each run's
files then encoded and xz-compressed one by one, as the pack does, to split its size into what
grows with the generations (a ``log.csv`` row, a kept best genome per unit of |G|, a thinned
line's digest, two sealed digests per generation in the checkpoint) and what does not (the
checkpoint's population per unit of |G|). The estimate puts those rates to ``paper-rq1``:
3000 generations, 12 runs (biped and worm, topology and weights-only, 3 seeds), the kept bests'
|G| from the paper's Table 1 (the final median for topology runs, whose genomes grow; the
initial size for weights-only runs, whose topology stays), the population's |G| likewise. It
prints JSON: the measured pack, the rates, the estimate in MB. Compressing files one by one
loses the matches between runs that the pack's one stream finds, so the estimate errs high.

    python benchmarks/pack_size.py CAMPAIGN_DIR [--generations 3000] [--seeds 3]
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import lzma
import sys
import tempfile
from pathlib import Path

from somite.campaigns import directory as campaign_dir
from somite.campaigns.pack import EVERY, LAST, _encode, _Tables, pack
from somite.errors import SomiteError
from somite.experiments.history import THINNED
from somite.report.paper import TABLE1


def _xz(data: bytes) -> int:
    return len(lzma.compress(data, format=lzma.FORMAT_XZ, preset=9 | lzma.PRESET_EXTREME))


def measure(folder: Path) -> dict:
    """One evolve run's compressed bytes per part, and the counts they divide by."""
    tables = _Tables()
    rows = list(csv.DictReader(io.StringIO((folder / "log.csv").read_text())))
    parts = {}
    for name, thin in (("log.csv", False), ("bests.jsonl", True), ("checkpoint.json", False)):
        data = (folder / name).read_bytes()
        _, stored, back = _encode(folder / name, data, tables, thin)
        parts[name] = {"bytes": len(data), "compressed": _xz(stored)}
        if name == "bests.jsonl":
            lines = back.decode().splitlines()
            thinned = sum(1 for line in lines if THINNED.fullmatch(line))
            parts[name].update(kept=len(lines) - thinned, thinned=thinned)
        if name == "checkpoint.json":
            state = json.loads(data)
            parts[name]["population"] = len(state["population"])
            parts[name]["digests"] = sum(len(v) for v in (state.get("history") or {}).values())
    sizes = [float(r["best_size"]) for r in rows]
    kept = [s for g, s in enumerate(sizes) if g % EVERY == 0 or g >= len(sizes) - LAST]
    median_size = float(rows[-1]["median_size"])  # the checkpoint's population, about
    return {"run": str(folder), "generations": len(rows) - 1, "parts": parts,
            "kept_mean_size": sum(kept) / len(kept), "population_median_size": median_size}


def rates(runs: list[dict]) -> dict:
    """Compressed bytes per log row, per unit of |G| of a kept best, per thinned line, per
    sealed digest and per unit of |G| of a checkpoint's genome, over the measured runs (the
    digests and thinned lines taken at their 4 bytes of entropy, which xz cannot shrink)."""
    rows = sum(r["generations"] + 1 for r in runs)
    log = sum(r["parts"]["log.csv"]["compressed"] for r in runs)
    thinned_bytes = 4.5
    bests = sum(r["parts"]["bests.jsonl"]["compressed"] - thinned_bytes
                * r["parts"]["bests.jsonl"]["thinned"] for r in runs)
    kept_units = sum(r["parts"]["bests.jsonl"]["kept"] * r["kept_mean_size"] for r in runs)
    checkpoint = sum(r["parts"]["checkpoint.json"]["compressed"]
                     - 4 * r["parts"]["checkpoint.json"]["digests"] for r in runs)
    population_units = sum(r["parts"]["checkpoint.json"]["population"]
                           * r["population_median_size"] for r in runs)
    return {"log_row": log / rows, "kept_best_per_size": bests / kept_units,
            "thinned_line": thinned_bytes, "sealed_digest": 4.0,
            "checkpoint_genome_per_size": checkpoint / population_units}


def estimate(rate: dict, generations: int, seeds: int, population: int = 96) -> dict:
    """Bytes of a pack of paper-rq1 (``seeds`` per shape and variant)."""
    kept = len({g for g in range(generations + 1)
                if g % EVERY == 0 or g >= generations + 1 - LAST})
    per_run = {}
    for shape, table in TABLE1.items():
        for variant, size in (("topology", table["final"]["size"].value),
                              ("weights-only", table["initial"]["size"].value)):
            per_run[f"{shape}, {variant}"] = (
                (generations + 1) * rate["log_row"]
                + kept * size * rate["kept_best_per_size"]
                + (generations + 1 - kept) * rate["thinned_line"]
                + 2 * (generations + 1) * rate["sealed_digest"]
                + population * size * rate["checkpoint_genome_per_size"]
                + 4000)  # best.json, config.json, manifest, physics, done.json
    total = seeds * sum(per_run.values())
    return {"generations": generations, "runs": seeds * len(per_run),
            "per_run_kB": {k: round(v / 1e3, 1) for k, v in per_run.items()},
            "total_MB": round(total / 1e6, 2)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="pack_size.py", description=__doc__.splitlines()[0])
    parser.add_argument("campaign", help="a campaign directory holding evolve runs")
    parser.add_argument("--generations", type=int, default=3000)
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args(argv)
    root = Path(args.campaign)
    try:
        doc = campaign_dir.read(root)
        runs = [measure(root / t["path"]) for t in doc["tasks"]
                if t["kind"] == "evolve" and (root / t["path"] / "checkpoint.json").is_file()]
        with tempfile.TemporaryDirectory() as scratch:
            packed = pack(root, Path(scratch) / "measured.pack")
    except SomiteError as error:
        sys.stderr.write(f"{parser.prog}: error: {error}\n")
        return 2
    rate = rates(runs)
    json.dump({"measured": {"pack_bytes": packed.bytes, "files_bytes": packed.size,
                            "bests_kept": packed.bests_kept,
                            "bests_thinned": packed.bests_thinned, "runs": runs},
               "rates_bytes": {k: round(v, 2) for k, v in rate.items()},
               "paper_rq1": estimate(rate, args.generations, args.seeds)},
              sys.stdout, indent=1)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
