"""The fourth probe's classes (issue 46), re-run: hostile and careless calls of the Python API,
the environment and signals, and the files a run or campaign reads back.

Every case is a call that must either be refused (a one-line SomiteError whose message starts
with the argument's name) or answered (it returns: a valid but extreme value). The API cases
run in a child process, one after another, each with a timeout: a case that kills the child
is a crash, one past its timeout a hang (the child is started again after either). A refused
case that returns is a silent acceptance; any other exception, or a SomiteError that does not
name the argument, is an unclear error. The command-line cases run ``somite`` as a
subprocess and must end with exit code 2 (130 for the signals) and one line on stderr.

Prints a JSON object: the counts per class and, for each case not handled, what happened.

Usage: python audits/api_probe.py [--timeout 60] [--only WORD]
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REFUSED, ANSWERED = "refused", "answered"

SETUP = """
import math, json
import numpy as np
import somite
from somite.brain.compile import compile_genome
from somite.brain.controllers import GraphArrays
from somite.evolution.operators import initial_genome
worm = somite.Body.build("worm"); biped = somite.Body.build("biped")
rng = np.random.default_rng(46)
g = initial_genome(worm, rng); gb = initial_genome(biped, rng)
cfg = somite.SimConfig(duration=1 / 60)
flat = somite.parse_terrain("flat")
def asked():
    ea = somite.GraphEA(worm, population=4, seed=0)
    return ea, ea.ask()
def told(fitness, **kw):
    ea, genomes = asked()
    ea.tell(genomes, fitness, **kw)
    json.dumps(ea.state(), allow_nan=False)
def stepped(actuation):
    e = somite.Episode([g], "flat", somite.SimConfig(duration=2 / 60))
    e.step(actuation)
"""


def api_cases() -> list[tuple[str, str, str, str]]:
    """(class, field, code, expected): the code runs after :data:`SETUP`."""
    out = []

    def case(field, code, expected=REFUSED, group="API"):
        out.append((group, field, code, expected))

    # 1. body/controller mismatches (the segfault)
    case("controllers[0]", "somite.Episode([compile_genome(g)], 'flat', cfg, bodies=[biped])")
    case("controllers[0]", "somite.Episode([compile_genome(gb)], 'flat', cfg, bodies=[worm])")
    case("bodies[0]", "somite.Episode([g], 'flat', cfg, bodies=[biped])")
    # A graph built by hand, without the body it was compiled for: refused when it refers
    # past its robot's readings or voxels; within them it runs (in bounds) as it was asked.
    case("controllers[0]", "a = compile_genome(g); somite.Episode([GraphArrays(a.node_kind, "
         "a.node_ref, a.src, a.dst, a.weight, a.bias)], 'flat', cfg, bodies=[biped])")
    case("controllers[0]", "a = compile_genome(gb); somite.Episode([GraphArrays(a.node_kind, "
         "a.node_ref, a.src, a.dst, a.weight, a.bias)], 'flat', cfg, bodies=[worm])", ANSWERED)
    case("controllers[0]", "somite.simulate_batch([biped], [flat], [compile_genome(g)], cfg)")
    case("body", "somite.simulate(g, body=biped, sim=cfg)")
    case("shape", "somite.GraphEA(biped, start=g)")
    # 2. SimConfig numbers
    huge = {"substeps": "2**40", "velocity_iterations": "2**31", "position_iterations": "2**31",
            "touch_window": "10**12", "velocity_window": "10**12", "start_gap": "1e300",
            "duration": "1e9", "transient": "1e9", "spring_hz": "1e300", "gravity": "1e300",
            "drag": "1e300", "friction": "1e300", "block_friction": "1e300",
            "restitution": "2.0", "noise_sigma": "1e300", "lidar_range": "1e300",
            "velocity_max": "1e300", "damping_ratio": "1e300", "area_delta": "1.0"}
    for name, value in huge.items():
        case(name, f"somite.SimConfig({name}={value})")
        case(name, f"somite.SimConfig({name}='1')")
    for name in ("duration", "gravity", "spring_hz"):
        case(name, f"somite.SimConfig({name}=float('nan'))")
        case(name, f"somite.SimConfig({name}=True)")
    case("substeps", "somite.SimConfig(substeps=2.0)")
    case("lidar_angles", "somite.SimConfig(lidar_angles=(0.0,) * 4)")
    case("lidar_angles[0]", "somite.SimConfig(lidar_angles=(1e9, 0, 0, 0, 0))")
    case("hidden_activation", "somite.SimConfig(hidden_activation=None)")
    case("option", "somite.SimConfig().with_options(substep=2)")
    case("preset", "somite.preset(['paper'])")
    case("substeps", "somite.SimConfig(substeps=100, duration=1/60)", ANSWERED)
    case("start_gap", "somite.SimConfig(start_gap=10_000.0)", ANSWERED)
    # 3. tell
    for value in ("math.inf", "-math.inf", "10**400", "'0.1'", "None", "True", "1j",
                  "np.complex128(1)"):
        case("fitness[0]", f"told([{value}, 0.1, 0.2, 0.3])")
    case("fitness", "told([0.1] * 3)")
    case("fitness", "told('0.1 0.2 0.3 0.4')")
    case("fitness", "told(np.zeros((2, 2)))")
    case("fitness", "told(None)")
    for value in ("-3", "2.9", "10**30", "True", "'1'"):
        case("non_finite", f"told([0.1] * 4, non_finite={value})")
    case("fitness", "told([math.nan, 0.1, 0.2, 0.3], non_finite=1)", ANSWERED)
    case("fitness", "told(np.array([0.1, 0.2, 0.3, 0.4], dtype=np.float32))", ANSWERED)
    # 6. documented limits and types
    case("evaluations", "somite.Locomotion(evaluations=1001)")
    case("evaluations", "somite.Locomotion(evaluations=2.0)")
    case("validation", "somite.Locomotion(validation=1001)")
    case("terrains", "somite.evaluate_genomes([g], ['flat'] * 1001, cfg)")
    case("robots", "somite.Episode([somite.Zero()] * 100_000, 'flat', cfg, "
         "bodies=[worm] * 100_000)")
    case("duration", "somite.simulate(g, duration='1')")
    case("duration", "somite.simulate(g, duration=601.0)")
    case("duration", "somite.simulate(g, duration='1', sim=cfg)")
    case("config", "somite.Episode([g], 'flat', {'duration': 1.0})")
    case("bodies[0]", "somite.Episode([somite.Zero()], 'flat', cfg, bodies=['worm'])")
    case("bodies", "somite.Episode([somite.Zero()], 'flat', cfg, bodies=worm)")
    case("bodies", "somite.Episode([somite.Zero()], 'flat', cfg)")
    case("robots", "somite.Episode(g, 'flat', cfg)")
    case("robots", "somite.Episode([], 'flat', cfg)")
    case("seeds", "somite.Episode([g], 'flat', cfg, seeds=['7'])")
    case("seeds", "somite.Episode([g], 'flat', cfg, seeds=[2.7])")
    case("seeds", "somite.Episode([g], 'flat', cfg, seeds=2**64)")
    case("seeds", "somite.Episode([g], 'flat', cfg, seeds=[1, 2])")
    case("record", "somite.Episode([g], 'flat', cfg, record='yes')")
    case("terrains", "somite.Episode([g], 5, cfg)")
    case("terrains[0]", "somite.Episode([g], ['nowhere'], cfg)")
    case("genomes[0]", "somite.evaluate_genomes(['g'], ['flat'], cfg)")
    case("genomes", "somite.evaluate_genomes(g, ['flat'], cfg)")
    case("config", "somite.evaluate_genomes([g], ['flat'], {'duration': 1})")
    case("terrains", "somite.evaluate_genomes([g], 'flat', cfg)")
    case("seed", "somite.evaluate_genomes([g], ['flat'], cfg, seed=-1)")
    case("shape", "somite.Body.build(None)")
    case("shape", "somite.Body.build(5)")
    case("shape", "somite.Body.build('33x1')")
    case("sensors", "somite.Body.build('worm', sensors=[1])")
    case("sensors", "somite.Body.build('worm', sensors={1: 2})")
    case("robot", "somite.simulate(5, body=worm)")
    case("body", "somite.simulate(somite.Zero(), body='worm')")
    case("body", "somite.simulate(somite.Zero())")
    case("seed", "somite.simulate(g, seed=2.0, sim=cfg)")
    case("seed", "somite.simulate(g, seed=2**32, sim=cfg)")
    case("backend", "somite.simulate(g, backend=None, sim=cfg)")
    case("backend", "somite.simulate(g, backend='tpu', sim=cfg)")
    case("terrain", "somite.simulate(g, terrain=None, sim=cfg)")
    case("preset", "somite.simulate(g, preset='fast', sim=cfg)")
    case("sim", "somite.simulate(g, sim={'duration': 1})")
    case("terrain", "somite.Locomotion(terrain=3)")
    case("terrain", "somite.Locomotion(terrain='hilly-1-10-10000')")
    case("duration", "somite.Locomotion(duration='1')")
    case("transient", "somite.Locomotion(transient=-1.0)")
    case("sim", "somite.Locomotion(sim={'duration': 1.0})")
    case("body", "somite.Locomotion(body='worm')")
    case("backend", "somite.Locomotion(backend=1)")
    case("rng", "somite.Locomotion(duration=1.0).evaluate([g], rng=3)")
    case("genomes", "somite.Locomotion(duration=1.0).evaluate(g, np.random.default_rng(0))")
    case("genomes[0]", "somite.Locomotion(duration=1.0).evaluate([1], np.random.default_rng(0))")
    case("start", "somite.GraphEA(worm, start='best.json')")
    case("seed", "somite.GraphEA(worm, seed='1')")
    case("seed", "somite.GraphEA(worm, seed=2**32)")
    case("body", "somite.GraphEA('worm')")
    case("population", "somite.GraphEA(worm, population=0)")
    case("population", "somite.GraphEA(worm, population=10_001)")
    case("population", "somite.GraphEA(worm, population=4.0)")
    case("n", "somite.fresh_noise(g, flat, cfg, n=0)")
    for value in ("[['0.5'] * 12]", "np.full((1, 12), 0.5 + 0j)", "'0.5'", "[[0.5] * 11]",
                  "[[2.0] * 12]", "[[math.nan] * 12]", "np.full((1, 12), True)", "object()"):
        case("actuation", f"stepped({value})")
    case("actuation", "stepped(np.full((1, 12), 0.5, dtype=np.float32))", ANSWERED)
    case("actuation", "stepped(None)", ANSWERED)
    # 7. start named in a configuration
    case("start", "import tempfile; d = tempfile.mkdtemp(); somite.evolve(somite.resolve("
         "{'shape': 'worm', 'population': 2, 'generations': 0, 'duration': 1.0, "
         "'start': '/dev/zero'}), d + '/run')")
    # 8. strict JSON
    case("genome", "t = g.to_compact(); somite.Genome.from_compact(t[:-1] + ',\"edges\":[]}')")
    case("colour", "d = g.to_dict(); d['colour'] = 'x' * 10**6; somite.Genome.from_dict(d)")
    case("nodes[0].colour", "d = g.to_dict(); d['nodes'][0]['colour'] = 1; "
         "somite.Genome.from_dict(d)")
    case("edges[0].colour", "d = g.to_dict(); d['edges'][0]['colour'] = 1; "
         "somite.Genome.from_dict(d)")
    case("body.colour", "d = g.to_dict(); d['body']['colour'] = 1; somite.Genome.from_dict(d)")
    return out


CHILD = r"""
import json, sys, traceback
exec(sys.argv[1])
from somite.errors import SomiteError
for line in sys.stdin:
    index, code = json.loads(line)
    print(json.dumps({"start": index}), flush=True)
    try:
        exec(code)
        result = {"index": index, "outcome": "returned"}
    except SomiteError as error:
        result = {"index": index, "outcome": "SomiteError", "message": str(error)}
    except BaseException as error:
        result = {"index": index, "outcome": type(error).__name__,
                  "message": str(error)[:300]}
    print(json.dumps(result), flush=True)
"""


def _read_lines(stream, lines: queue.Queue) -> None:
    for line in stream:
        lines.put(line)
    lines.put(None)


def run_api(cases, timeout: float) -> list[dict]:
    """Each case in a child (started again after a crash or a hang)."""
    results: dict[int, dict] = {}
    pending = list(range(len(cases)))
    while pending:
        child = subprocess.Popen([sys.executable, "-c", CHILD, SETUP], stdin=subprocess.PIPE,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        lines: queue.Queue = queue.Queue()
        threading.Thread(target=_read_lines, args=(child.stdout, lines), daemon=True).start()
        for index in pending:
            child.stdin.write(json.dumps([index, cases[index][2]]) + "\n")
        child.stdin.close()
        current, wait = None, timeout * 5  # the first case also imports and loads kernels
        while True:
            try:
                line = lines.get(timeout=wait)
            except queue.Empty:
                child.kill()
                child.wait()
                results[current] = {"index": current, "outcome": "hang"}
                break
            if line is None:  # the child ended
                child.wait()
                if current is not None:
                    err = child.stderr.read()[-300:]
                    results[current] = {"index": current, "outcome": "crash",
                                        "message": f"exit {child.returncode}: {err}"}
                break
            item = json.loads(line)
            if "start" in item:
                current, wait = item["start"], timeout
            else:
                results[item["index"]] = item
                current = None
        pending = [i for i in pending if i not in results]
    return [results[i] for i in range(len(cases))]


def classify(case, result) -> str:
    group, field, code, expected = case
    outcome = result["outcome"]
    if outcome in ("hang", "crash"):
        return outcome
    if outcome == "returned":
        return "handled" if expected == ANSWERED else "silent"
    if outcome == "SomiteError" and expected == REFUSED and result["message"].startswith(
            field) and "\n" not in result["message"]:
        return "handled"
    return "unclear"


def cli_cases(root: Path) -> list[tuple[str, str, list[str], dict, int]]:
    """(class, name, arguments, environment, expected exit code)."""
    genome = root / "dup.json"
    toml = root / "start.toml"
    toml.write_text('start = "/dev/zero"\n')
    return [
        ("environment, signals", "NUMBA_NUM_THREADS=0",
         ["simulate", "--duration", "0.1"], {"NUMBA_NUM_THREADS": "0"}, 2),
        ("environment, signals", "NUMBA_NUM_THREADS=abc",
         ["simulate", "--duration", "0.1"], {"NUMBA_NUM_THREADS": "abc"}, 2),
        ("environment, signals", "NUMBA_NUM_THREADS=100000",
         ["simulate", "--duration", "0.1"], {"NUMBA_NUM_THREADS": "100000"}, 2),
        ("environment, signals", "MPLBACKEND=nonsense",
         ["plot", str(root)], {"MPLBACKEND": "nonsense"}, 2),
        ("CLI files", "start in an evolve TOML",
         ["evolve", "--config", str(toml), "--out", str(root / "run"), "--quiet"], {}, 2),
        ("CLI files", "a genome with a key twice",
         ["draw", str(genome), "--out", str(root / "b.svg")], {}, 2),
    ]


def run_cli(case, root: Path, timeout: float) -> dict:
    group, name, args, env, expected = case
    try:
        child = subprocess.run([sys.executable, "-m", "somite.cli", *args],
                               env={**os.environ, **env}, capture_output=True, text=True,
                               timeout=timeout, cwd=root)
        code, err = child.returncode, child.stderr
    except subprocess.TimeoutExpired:
        return {"outcome": "hang"}
    ok = code == expected and err.count("\n") == 1 and "Traceback" not in err
    return {"outcome": "handled" if ok else "unclear", "exit": code, "stderr": err[-300:]}


def run_signals(timeout: float) -> dict:
    """SIGINT, then SIGTERM 10 ms later, during a long simulation: exit 130, one line."""
    child = subprocess.Popen([sys.executable, "-m", "somite.cli", "simulate", "--duration",
                              "600"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(min(timeout, 8.0))
    child.send_signal(signal.SIGINT)
    time.sleep(0.01)
    child.send_signal(signal.SIGTERM)
    try:
        _, err = child.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        child.kill()
        return {"outcome": "hang"}
    ok = child.returncode == 130 and err.count("\n") == 1 and "Traceback" not in err
    return {"outcome": "handled" if ok else "unclear", "exit": child.returncode,
            "stderr": err[-300:]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds a case may take")
    parser.add_argument("--only", default="", help="only the cases whose code holds this")
    args = parser.parse_args()
    started = time.perf_counter()
    cases = [c for c in api_cases() if args.only in c[2]]
    counts: dict[str, dict[str, int]] = {}
    failures = []

    def count(group, kind, detail):
        row = counts.setdefault(group, {"tried": 0, "handled": 0, "unclear": 0, "silent": 0,
                                        "hang": 0, "crash": 0})
        row["tried"] += 1
        row[kind] += 1
        if kind != "handled":
            failures.append(detail)

    for case, result in zip(cases, run_api(cases, args.timeout)):
        count(case[0], classify(case, result), {"case": case[2], "field": case[1], **result})
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        import numpy as np

        import somite
        from somite.evolution.operators import initial_genome

        text = initial_genome(somite.Body.build("worm"),
                              np.random.default_rng(0)).to_compact()
        (root / "dup.json").write_text(text[:-1] + ',"edges":[]}')
        for case in cli_cases(root):
            if args.only not in case[1]:
                continue
            result = run_cli(case, root, args.timeout)
            count(case[0], result["outcome"], {"case": case[1], **result})
    if args.only in "signals":
        result = run_signals(args.timeout)
        count("environment, signals", result["outcome"],
              {"case": "SIGINT then SIGTERM", **result})
    total = {k: sum(row[k] for row in counts.values())
             for k in ("tried", "handled", "unclear", "silent", "hang", "crash")}
    print(json.dumps({"counts": counts, "total": total, "not_handled": failures,
                      "seconds": round(time.perf_counter() - started, 1)}, indent=1))


if __name__ == "__main__":
    main()
