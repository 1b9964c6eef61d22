"""The probe of issue 10, re-run: hostile input to every command, as a user would type it.

Each case runs ``python -m somite.cli ...`` as a subprocess with a timeout, in a scratch folder
holding a small finished run, a genome, a partition and a module library. A case passes when
it ends as it should: refused (exit 2, one line on stderr, no traceback, nothing written or
changed anywhere in the scratch folder) or, for input that is valid but extreme, answered
(exit 0, no traceback). Prints a JSON summary (one object per case: its exit code, stderr
lines, traceback or not, the files it wrote, changed or deleted, and whether it passed) and,
with ``--markdown FILE``, writes a Markdown table.

Usage: python audits/probe.py [--markdown audits/probe.md] [--only WORD]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PY = [sys.executable, "-m", "somite.cli"]
TIMEOUT = 120.0
SIM = ["--duration", "0.5"]


def snapshot(root: Path) -> dict[str, tuple]:
    """Every entry under ``root``: kind, and size and content hash for files."""
    entries = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        if path.is_symlink():
            entries[rel] = ("link", os.readlink(path))
        elif path.is_fifo():
            entries[rel] = ("fifo",)
        elif path.is_dir():
            entries[rel] = ("dir",)
        else:
            entries[rel] = ("file", hash(path.read_bytes()))
    return entries


def difference(before: dict, after: dict) -> dict[str, list[str]]:
    return {
        "written": sorted(set(after) - set(before)),
        "changed": sorted(k for k in set(after) & set(before) if after[k] != before[k]),
        "deleted": sorted(set(before) - set(after)),
    }


def run(args: list[str], cwd: Path, timeout: float = TIMEOUT) -> dict:
    start = time.perf_counter()
    try:
        child = subprocess.run([*PY, *args], cwd=cwd, capture_output=True, text=True,
                               timeout=timeout, errors="backslashreplace")
        code, err = child.returncode, child.stderr
    except subprocess.TimeoutExpired as expired:
        code = "timeout"
        err = expired.stderr.decode(errors="replace") if expired.stderr else ""
    return {"exit": code, "stderr_lines": err.count("\n"), "stderr": err.strip()[-300:],
            "traceback": "Traceback" in err, "seconds": round(time.perf_counter() - start, 1)}


# -- the scratch folder -------------------------------------------------------------------------


def prepare(root: Path) -> None:
    """A small run, a genome, a partition, a library; the bad files the cases point at."""
    def ok(*args):
        result = run(list(args), root)
        assert result["exit"] == 0, (args, result)

    ok("evolve", "--shape", "worm", "--population", "4", "--generations", "2", "--duration", "1",
       "--seed", "1", "--quiet", "--out", "run")
    ok("evolve", "--shape", "biped", "--population", "4", "--generations", "2", "--duration",
       "1", "--seed", "1", "--quiet", "--out", "biped")
    shutil.copy(root / "run" / "best.json", root / "genome.json")
    ok("discover", "run", "--out", "found")
    (root / "library").mkdir()
    ok("module", "export", "run", "--partition", "worm-halves", "--module", "back", "--out",
       "library/back.json")
    bad = root / "bad"
    bad.mkdir()
    genome = json.loads((root / "genome.json").read_text())
    deep = "[" * 200_000 + "]" * 200_000
    for name in ("genome", "checkpoint", "partition", "module"):
        (bad / f"deep-{name}.json").write_text(deep)
    def write(name, data):
        return ((bad / name).write_text(json.dumps(data)))
    write("huge-weight.json", edited(genome, lambda g: g["edges"][0].update(weight=1e308)))
    write("minus-huge-weight.json",
          edited(genome, lambda g: [e.update(weight=-1e308, bias=1e308) for e in g["edges"]]))
    (bad / "long-int-weight.json").write_text(
        json.dumps(genome).replace(f'"weight": {json.dumps(genome["edges"][0]["weight"])}',
                                   '"weight": ' + "9" * 500, 1))
    write("long-int-id.json", edited(genome, lambda g: g["nodes"][0].update(id=10**300)))
    write("sensors-int.json", edited(genome, lambda g: g["body"].update(sensors=5)))
    write("sensors-dict.json", edited(genome, lambda g: g["body"].update(sensors={"a": 1})))
    write("not-a-genome.json", [1, 2, 3])
    module = json.loads((root / "library" / "back.json").read_text())
    (bad / "library-deep").mkdir()
    (bad / "library-deep" / "back.json").write_text(deep)
    (bad / "library-huge").mkdir()
    (bad / "library-huge" / "back.json").write_text(json.dumps(module).replace(
        '"weight": ', '"weight": 1e308, "x": ', 1))
    os.mkfifo(bad / "fifo.json")
    (bad / "latin1.toml").write_bytes(b"# caf\xe9\nshape = 'worm'\n")
    (bad / "folder.toml").mkdir()
    (bad / "seed.toml").write_text(f"seed = {2**32}\n")
    (bad / "huge.toml").write_text("population = 100000000\n")
    (bad / "afile").write_text("a file\n")
    (bad / "dangling").symlink_to(bad / "nowhere")
    (bad / "x.png").mkdir()
    for name, config in (("config-list", "[]"), ("config-string-duration",
                                                 json.dumps({**json.loads(
                                                     (root / "run" / "config.json").read_text()),
                                                     "duration": "long"}))):
        shutil.copytree(root / "run", bad / name)
        (bad / name / "config.json").write_text(config)
    for name, text in (("toml-inf", "duration = inf\n"), ("toml-nan", "omega = nan\n"),
                       ("toml-string", "population = 'many'\n"), ("toml-table", "[shape]\n"),
                       ("toml-shape-int", "shape = 5\n"), ("toml-unknown", "colour = 1\n"),
                       ("toml-broken", "population = \n")):
        (bad / f"{name}.toml").write_text(text)
    write("big-body.json", edited(genome, lambda g: g["body"].update(
        shape="/".join(["1" * 1000] * 1000))))
    os.mkfifo(bad / "fifo.svg")
    for name, content in (("latin1-log", b"generation\xe9\n"), ("garbage-log", b"\x00" * 100)):
        shutil.copytree(root / "run", bad / name)
        (bad / name / "log.csv").write_bytes(content)
    shutil.copytree(root / "run", bad / "config-bool")
    (bad / "config-bool" / "config.json").write_text(json.dumps(
        {**json.loads((root / "run" / "config.json").read_text()), "population": True}))
    checkpoint = json.loads((root / "run" / "checkpoint.json").read_text())
    for name, generation in (("gen-minus5", -5), ("gen-million", 10**6)):
        shutil.copytree(root / "run", bad / name)
        (bad / name / "checkpoint.json").write_text(
            json.dumps({**checkpoint, "generation": generation}))
    shutil.copytree(root / "run", bad / "foreign-checkpoint")
    shutil.copy(root / "biped" / "checkpoint.json", bad / "foreign-checkpoint" / "checkpoint.json")
    shutil.copytree(root / "run", bad / "deep-checkpoint")
    shutil.copy(bad / "deep-checkpoint.json", bad / "deep-checkpoint" / "checkpoint.json")


def edited(data: dict, change) -> dict:
    copy = json.loads(json.dumps(data))
    change(copy)
    return copy


# -- the cases ----------------------------------------------------------------------------------

REFUSED, ANSWERED = "refused", "answered"


def cases() -> list[tuple[str, str, list[str], str]]:
    """(category, name, arguments, expected)."""
    out = []

    def case(category, name, args, expected=REFUSED):
        out.append((category, name, args, expected))

    writers = {
        "simulate": None,
        "evolve": ["evolve", "--population", "2", "--generations", "0", *SIM, "--quiet",
                   "--out", "{OUT}"],
        "reoptimize": ["reoptimize", "genome.json", "--population", "2", "--generations", "0",
                       *SIM, "--validation", "1", "--quiet", "--out", "{OUT}"],
        "discover": ["discover", "run", "--out", "{OUT}"],
        "module export": ["module", "export", "run", "--partition", "worm-halves", "--module",
                          "back", "--out", "{OUT}/back.json"],
        "assemble": ["assemble", "library", "--place", "back@0,0", "--out", "{OUT}"],
        "reassemble": ["reassemble", "run", "genome.json", "--partition", "worm-halves",
                       "--validation", "0", "--out", "{OUT}"],
        "draw": ["draw", "genome.json", "--out", "{OUT}/b.svg"],
        "show": ["show", "genome.json", *SIM, "--out", "{OUT}/s.png"],
        "plot": ["plot", "run", "--out", "{OUT}/p.png"],
        "demo": ["demo", "--generations", "0", "--quiet", "--out", "{OUT}"],
    }
    places = {
        "a file": "bad/afile",
        "a dangling symlink": "bad/dangling",
        "below a file": "bad/afile/below",
        "in /proc": "/proc/somite-probe",
        "in /sys": "/sys/somite-probe",
    }
    for command, args in writers.items():
        if args is None:
            continue
        for where, path in places.items():
            case("unwritable output", f"{command} --out {where}",
                 [a.replace("{OUT}", path) for a in args])
    case("unwritable output", "draw --out x.png that is a folder",
         ["draw", "genome.json", "--out", "bad/x.png"])
    case("unwritable output", "show --out x.png that is a folder",
         ["show", "genome.json", *SIM, "--out", "bad/x.png"])
    case("unwritable output", "plot --out x.png that is a folder",
         ["plot", "run", "--out", "bad/x.png"])

    for command, args in (
        ("simulate", ["simulate"]),
        ("bench", ["bench", "--robots", "4", "--no-scaling", "--shapes", "worm"]),
        ("evolve", ["evolve", "--population", "2", "--generations", "0", "--quiet", "--out",
                    "cases/e"]),
        ("evaluate", ["evaluate", "genome.json", "--validation", "1"]),
        ("show", ["show", "genome.json", "--out", "cases/s.png"]),
        ("reassemble", ["reassemble", "run", "run", "--partition", "worm-halves", "--validation",
                        "1", "--out", "cases/r"]),
        ("assemble", ["assemble", "library", "--place", "back@0,0", "--evaluate", "1", "--out",
                      "cases/a"]),
    ):
        for value in ("1e308", "1e6", "inf", "nan", "-1", "1e-9", "0"):
            case("numbers", f"{command} --duration {value}", [*args, "--duration", value])
    case("numbers", "show --fps 0.001", ["show", "genome.json", *SIM, "--fps", "0.001", "--out",
                                         "cases/s.gif"])
    case("numbers", "show --fps 1e308", ["show", "genome.json", *SIM, "--fps", "1e308", "--out",
                                         "cases/s.gif"])
    case("numbers", "show --width 1e9", ["show", "genome.json", *SIM, "--width", "1000000000",
                                         "--out", "cases/s.png"])
    case("numbers", "simulate --seed 2**64", ["simulate", *SIM, "--seed", str(2**64)])
    case("numbers", "simulate sine:freq=1e308 (answered, non_finite reported)",
         ["simulate", *SIM, "--controller", "sine:freq=1e308"], ANSWERED)

    case("size limits", "simulate --duration 1e6", ["simulate", "--duration", "1e6"])
    case("size limits", "evolve --population 100000000",
         ["evolve", "--population", "100000000", "--out", "cases/p"])
    case("size limits", "evolve --generations 10**12",
         ["evolve", "--generations", str(10**12), "--out", "cases/g"])
    case("size limits", "simulate --shape 1000x1000", ["simulate", "--shape", "1000x1000"])
    case("size limits", "show --frames 100000",
         ["show", "genome.json", *SIM, "--frames", "100000", "--out", "cases/f.png"])
    case("size limits", "evaluate --validation 100000",
         ["evaluate", "genome.json", *SIM, "--validation", "100000"])
    case("size limits", "reassemble --validation 100000",
         ["reassemble", "run", "run", "--partition", "worm-halves", "--validation", "100000",
          "--out", "cases/r"])
    case("size limits", "evolve --evaluations 10**9",
         ["evolve", "--evaluations", str(10**9), "--out", "cases/v"])
    case("size limits", "bench --robots 10**20", ["bench", "--robots", str(10**20)])
    case("size limits", "TOML population 10**8",
         ["evolve", "--config", "bad/huge.toml", "--out", "cases/t"])

    readers = {
        "genome": lambda f: ["evaluate", f, *SIM, "--validation", "1"],
        "partition": lambda f: ["draw", "genome.json", "--partition", f, "--out", "cases/b.svg"],
    }
    case("deep JSON", "genome 200000 deep (evaluate)", readers["genome"]("bad/deep-genome.json"))
    case("deep JSON", "genome 200000 deep (discover)",
         ["discover", "bad/deep-genome.json", "--out", "cases/d"])
    case("deep JSON", "partition 200000 deep", readers["partition"]("bad/deep-partition.json"))
    case("deep JSON", "module 200000 deep", ["module", "list", "bad/library-deep"])
    case("deep JSON", "module 200000 deep (assemble)",
         ["assemble", "bad/library-deep", "--place", "back@0,0", "--out", "cases/a"])
    case("deep JSON", "checkpoint 200000 deep",
         ["evolve", "--out", "bad/deep-checkpoint", "--resume", "--quiet"])

    for name in ("long-int-weight", "long-int-id", "huge-weight", "minus-huge-weight"):
        for command, args in (
            ("evaluate", ["evaluate", f"bad/{name}.json", *SIM, "--validation", "1"]),
            ("discover", ["discover", f"bad/{name}.json", "--out", "cases/d"]),
            ("module export", ["module", "export", f"bad/{name}.json", "--partition",
                               "worm-halves", "--module", "back", "--out", "cases/m/back.json"]),
            ("reassemble", ["reassemble", f"bad/{name}.json", "genome.json", "--partition",
                            "worm-halves", "--validation", "0", "--out", "cases/r"]),
        ):
            category = "huge ints" if "long-int" in name else "+-1e308 weights"
            case(category, f"{name} in {command}", args)
    case("+-1e308 weights", "module with weight 1e308 (module list)",
         ["module", "list", "bad/library-huge"])

    for name in ("sensors-int", "sensors-dict", "not-a-genome"):
        case("wrong types", f"genome {name}", ["evaluate", f"bad/{name}.json", *SIM])
    case("wrong types", "config.json []", ["evolve", "--out", "bad/config-list", "--resume",
                                           "--quiet"])
    case("wrong types", "config.json string duration",
         ["evolve", "--out", "bad/config-string-duration", "--resume", "--quiet"])
    case("wrong types", "--population 2.5", ["evolve", "--population", "2.5", "--out", "cases/x"])
    case("wrong types", "--controller sine:freq=abc", ["simulate", "--controller",
                                                       "sine:freq=abc"])

    case("TOML", "TOML not UTF-8", ["evolve", "--config", "bad/latin1.toml", "--out", "cases/t"])
    case("TOML", "TOML a folder", ["evolve", "--config", "bad/folder.toml", "--out", "cases/t"])
    case("TOML", "TOML a FIFO", ["evolve", "--config", "bad/fifo.json", "--out", "cases/t"])
    case("TOML", "TOML seed 2**32", ["evolve", "--config", "bad/seed.toml", "--out", "cases/t"])
    case("TOML", "TOML missing", ["evolve", "--config", "bad/none.toml", "--out", "cases/t"])

    for command, args in (
        ("evaluate", ["evaluate", "bad/fifo.json", *SIM]),
        ("draw", ["draw", "bad/fifo.json", "--out", "cases/b.svg"]),
        ("discover", ["discover", "bad/fifo.json", "--out", "cases/d"]),
        ("reoptimize", ["reoptimize", "bad/fifo.json", "--out", "cases/re"]),
        ("draw --partition", ["draw", "genome.json", "--partition", "bad/fifo.json", "--out",
                              "cases/b.svg"]),
        ("evaluate a folder", ["evaluate", "bad/folder.toml", *SIM]),
    ):
        case("FIFO or folder as input", f"{command}", args)

    case("tiny duration", "simulate --duration 1e-9", ["simulate", "--duration", "1e-9"])
    case("tiny duration", "evaluate --duration 1e-9",
         ["evaluate", "genome.json", "--duration", "1e-9", "--validation", "1"])
    case("tiny duration", "evolve --duration 1e-9",
         ["evolve", "--duration", "1e-9", "--out", "cases/t"])

    case("checkpoints", "checkpoint of another run",
         ["evolve", "--out", "bad/foreign-checkpoint", "--resume", "--quiet"])
    case("checkpoints", "checkpoint generation -5",
         ["evolve", "--out", "bad/gen-minus5", "--resume", "--quiet"])
    case("checkpoints", "checkpoint generation 10**6",
         ["evolve", "--out", "bad/gen-million", "--resume", "--quiet"])

    case("bench", "bench --shapes ,", ["bench", "--shapes", ","])
    case("bench", "bench --shapes ' '", ["bench", "--shapes", " "])
    case("bench", "bench --shapes worm,nothing", ["bench", "--shapes", "worm,nothing",
                                                  "--robots", "4", "--no-scaling"])

    case("run directories", "discover a run directory (answered)",
         ["discover", "run", "--out", "cases/d"], ANSWERED)
    case("run directories", "module export a run directory (answered)",
         ["module", "export", "run", "--partition", "worm-halves", "--module", "back", "--out",
          "cases/m/back.json"], ANSWERED)
    case("run directories", "reassemble run directories (answered)",
         ["reassemble", "run", "run", "--partition", "worm-halves", "--validation", "0",
          "--out", "cases/r"], ANSWERED)
    case("run directories", "evolve into a run without --force",
         ["evolve", "--population", "2", "--generations", "0", "--out", "run"])

    # Variations: the same classes, other values.
    for name, _text in (("toml-inf", "duration = inf\n"), ("toml-nan", "omega = nan\n"),
                       ("toml-string", "population = 'many'\n"), ("toml-table", "[shape]\n"),
                       ("toml-shape-int", "shape = 5\n"), ("toml-unknown", "colour = 1\n"),
                       ("toml-broken", "population = \n")):
        case("TOML", name, ["evolve", "--config", f"bad/{name}.toml", "--out", "cases/t"])
    for terrain in ("hilly-1e308-10-3", "hilly-nan-10-3", "steppy-1-0-rnd", "hilly-1-10-" +
                    "9" * 400, "uphill-1e308", ""):
        case("numbers", f"simulate --terrain {terrain[:30]}", ["simulate", *SIM, "--terrain",
                                                                 terrain])
    for value in ("0", "-1", "nan", "1e308"):
        case("numbers", f"evolve --omega {value}", ["evolve", "--omega", value, "--population",
                                                    "2", "--generations", "0", "--out",
                                                    "cases/o"])
    case("numbers", "evolve --checkpoint-every 0", ["evolve", "--checkpoint-every", "0",
                                                    "--out", "cases/o"])
    case("numbers", "evolve --validate-every -1", ["evolve", "--validate-every", "-1",
                                                   "--out", "cases/o"])
    case("size limits", "show --width 20000 --height 20000",
         ["show", "genome.json", *SIM, "--width", "20000", "--height", "20000", "--out",
          "cases/s.png"])
    case("size limits", "assemble --place back@1000000,0 (answered: one module, placed)",
         ["assemble", "library", "--place", "back@1000000,0", "--out", "cases/a"], ANSWERED)
    case("size limits", "assemble --place back@-1,0 (answered: one module, placed)",
         ["assemble", "library", "--place", "back@-1,0", "--out", "cases/a"], ANSWERED)
    case("size limits", "assemble two modules 1000000 apart",
         ["assemble", "library", "--place", "back@1000000,0", "--place", "back@0,0", "--out",
          "cases/a"])
    case("size limits", "reassemble --receiver-shape 1000x1000",
         ["reassemble", "run", "run", "--partition", "worm-halves", "--receiver-shape",
          "1000x1000", "--validation", "0", "--out", "cases/r"])
    case("size limits", "genome of a 1000x1000 body", ["evaluate", "bad/big-body.json", *SIM])
    case("size limits", "discover --max 10**9", ["discover", "run", "--min", "1", "--max",
                                                 str(10**9), "--out", "cases/d"])
    case("unwritable output", "draw --out a FIFO", ["draw", "genome.json", "--out",
                                                    "bad/fifo.svg"])
    case("unwritable output", "evolve --out ''", ["evolve", "--out", ""])
    case("unwritable output", "draw --out ''", ["draw", "genome.json", "--out", ""])
    case("unwritable output", "a name that is not UTF-8 (answered)",
         ["draw", "genome.json", "--out", "cases/caf\udcff.svg"], ANSWERED)
    case("wrong types", "plot a log.csv that is not UTF-8", ["plot", "bad/latin1-log", "--out",
                                                             "cases/p.png"])
    case("wrong types", "plot a log.csv of garbage", ["plot", "bad/garbage-log", "--out",
                                                      "cases/p.png"])
    case("wrong types", "config.json population true",
         ["evolve", "--out", "bad/config-bool", "--resume", "--quiet"])
    case("wrong types", "module list a file", ["module", "list", "genome.json"])
    case("wrong types", "module list an empty folder (answered)", ["module", "list", "cases"],
         ANSWERED)
    case("wrong types", "simulate --sensors x", ["simulate", *SIM, "--sensors", "x"])
    case("wrong types", "evolve --modules x", ["evolve", "--modules", "x", "--out", "cases/x"])
    case("wrong types", "reassemble --take x=y", ["reassemble", "run", "run", "--partition",
                                                  "worm-halves", "--take", "x=y",
                                                  "--out", "cases/r"])
    for name, campaign in (("an empty folder", "cases"), ("a run directory", "run"),
                           ("a FIFO", "bad/fifo.json"), ("a file", "genome.json"),
                           ("missing", "bad/none")):
        case("report", f"report of {name}", ["report", campaign, "--quiet", "--out",
                                              "cases/rep"])
    case("report", "report --out in /proc", ["report", "run", "--out", "/proc/somite-probe"])
    case("report", "report --validation 100000", ["report", "run", "--validation", "100000",
                                                  "--out", "cases/rep"])
    case("run directories", "evolve --resume on an empty folder (answered)",
         ["evolve", "--resume", "--population", "2", "--generations", "0", *SIM, "--quiet",
          "--out", "cases"], ANSWERED)
    return out


def judge(result: dict, expected: str) -> bool:
    if result["traceback"] or result["exit"] == "timeout":
        return False
    changes = result["files"]
    if expected == REFUSED:
        return (result["exit"] == 2 and result["stderr_lines"] == 1
                and not any(changes.values()))
    return result["exit"] == 0


def concurrent(root: Path) -> list[dict]:
    """Two processes on one run directory: the second is refused while the first runs; after
    the first is killed, --resume takes its lock and ends as an uninterrupted run."""
    args = ["evolve", "--shape", "worm", "--population", "6", "--generations", "12",
            "--duration", "1", "--seed", "4", "--checkpoint-every", "3", "--quiet"]
    whole = run([*args, "--out", "conc-whole"], root)
    first = subprocess.Popen([*PY, *args, "--out", "conc"], cwd=root,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    log = root / "conc" / "log.csv"
    deadline = time.time() + TIMEOUT
    while not (log.is_file() and len(log.read_text().splitlines()) >= 4) and (
        time.time() < deadline and first.poll() is None
    ):
        time.sleep(0.01)
    os.kill(first.pid, signal.SIGSTOP)  # it holds the lock as long as the probe needs
    results = []
    try:
        for extra in ([], ["--force"], ["--resume"]):
            before = snapshot(root / "conc")
            result = run([*args, "--out", "conc", *extra], root)
            result["files"] = difference(before, snapshot(root / "conc"))
            result.update(category="concurrent runs", case=f"second evolve {' '.join(extra)} "
                          "while the first runs", expected=REFUSED)
            result["passed"] = judge(result, REFUSED) and "in use by process" in result["stderr"]
            results.append(result)
    finally:
        os.kill(first.pid, signal.SIGKILL)
        first.wait()
    result = run([*args, "--out", "conc", "--resume"], root)
    same = all((root / "conc" / n).read_bytes() == (root / "conc-whole" / n).read_bytes()
               for n in ("best.json", "bests.jsonl"))
    result.update(category="concurrent runs", case="--resume after SIGKILL of the first",
                  expected=ANSWERED, files={"written": [], "changed": [], "deleted": []},
                  same_as_uninterrupted=same)
    result["passed"] = whole["exit"] == 0 and judge(result, ANSWERED) and same
    results.append(result)
    return results


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--markdown", type=Path)
    parser.add_argument("--only", default="", help="run the cases whose name holds this")
    options = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="somite-probe-") as scratch:
        root = Path(scratch)
        prepare(root)
        (root / "cases").mkdir()
        results = []
        for category, name, args, expected in cases():
            if options.only not in name:
                continue
            before = snapshot(root)
            result = run(args, root)
            result["files"] = difference(before, snapshot(root))
            result.update(category=category, case=name, expected=expected)
            result["passed"] = judge(result, expected)
            results.append(result)
            # What a case wrote must not decide the next one.
            shutil.rmtree(root / "cases")
            (root / "cases").mkdir()
            print(f"{'ok  ' if result['passed'] else 'FAIL'} {name}: exit {result['exit']}",
                  file=sys.stderr)
        if "concurrent" in options.only or not options.only:
            results.extend(concurrent(root))
    summary = {"cases": len(results), "passed": sum(r["passed"] for r in results),
               "tracebacks": sum(r["traceback"] for r in results),
               "timeouts": sum(r["exit"] == "timeout" for r in results), "results": results}
    print(json.dumps(summary, indent=1))
    if options.markdown:
        options.markdown.write_text(markdown(summary))


def markdown(summary: dict) -> str:
    lines = [
        "# The probe of issue 10, re-run",
        "",
        "`python audits/probe.py --markdown audits/probe.md` (each case a subprocess of "
        "`python -m somite.cli`, timeout 120 s, in a scratch folder with a small run, a genome, "
        "a partition and a module library). Expected: *refused* = exit 2, one line on stderr, "
        "no traceback, nothing written, changed or deleted in the scratch folder; *answered* = "
        "exit 0, no traceback. Run as root, so a read-only folder is not one here: /proc and "
        "/sys stand for unwritable places.",
        "",
        f"**{summary['passed']} of {summary['cases']} cases pass**; tracebacks: "
        f"{summary['tracebacks']}, timeouts: {summary['timeouts']}.",
        "",
        "| category | case | expected | exit | stderr lines | traceback | files | s | pass |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["results"]:
        files = ", ".join(f"{k}: {len(v)}" for k, v in r["files"].items() if v) or "none"
        lines.append(f"| {r['category']} | {r['case']} | {r['expected']} | {r['exit']} | "
                     f"{r['stderr_lines']} | {'yes' if r['traceback'] else 'no'} | {files} | "
                     f"{r['seconds']} | {'yes' if r['passed'] else '**no**'} |")
    lines += ["", "The one line each refused case printed:", ""]
    for r in summary["results"]:
        if r["expected"] == REFUSED:
            text = r["stderr"].replace("|", "\\|").replace("\n", " / ")
            lines.append(f"- {r['case']}: `{text}`")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
