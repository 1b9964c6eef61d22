"""Campaigns: the TOML spec, the built-ins' tasks, and running them on Dask (a LocalCluster,
a scheduler and workers started by hand), killed and resumed, to the same logs."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from somite.campaigns.builtin import BUDGETS, BUILTINS, builtin
from somite.campaigns.expansion import expand
from somite.campaigns.spec import parse
from somite.cli import main
from somite.errors import SomiteError
from somite.experiments.config import resolve
from somite.experiments.runner import RUN_FILES

SOMITE = [sys.executable, "-m", "somite.cli"]
EVOLVE_FILES = {"config.json", "log.csv", "bests.jsonl", "best.json", "checkpoint.json",
                "manifest.json"}
OUTPUTS = {
    "evolve": EVOLVE_FILES,
    "reoptimize": EVOLVE_FILES | {"transfer.csv"},
    "reassemble": {"reassembled.json", "report.json", "report.csv"},
    "discover": {"partition.json", "candidates.csv"},
}


# -- the campaign file ------------------------------------------------------------------------

def _one_line_error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    return err


@pytest.mark.parametrize("text, field", [
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 0\n", "experiments.a.seeds"),
    ("[experiments.a]\nkind = 'grow'\n", "experiments.a.kind"),
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 2\nfoo = 1\n",
     "experiments.a.foo"),
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 2\n"
     "options = { population = 1 }\n", "experiments.a.population"),
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['blob']\nseeds = 2\n", "experiments.a.shape"),
    ("[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n", "experiments.b.donors"),
    ("[experiments.a]\nkind = 'discover'\ngenomes = 'a'\n", "experiments.a.genomes"),
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = [3]\n"
     "[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\n", "experiments.b.pairing"),
    ("validation = 0\n[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 1\n",
     "validation"),
    ("[experiments.a\n", "campaign"),
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['biped']\nseeds = 2\n"
     "[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\npartition = 'worm-halves'\n",
     "experiments.b.partition"),
    ("[experiments.a]\nkind = 'evolve'\nshapes = ['worm']\nseeds = 2\n"
     "[experiments.b]\nkind = 'reassemble'\ndonors = 'a'\nreoptimize = { foo = 1 }\n",
     "experiments.b.reoptimize.foo"),
])
def test_bad_campaign_files_are_one_line_errors(tmp_path, capsys, text, field):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    err = _one_line_error(capsys, ["campaign", "run", str(path), "--out", str(tmp_path / "o")])
    assert f"error: {field}=" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, field", [
    (["run", "smoke", "--workers", "0"], "workers"),
    (["run", "smoke", "--threads", "0"], "threads"),
    (["run", "smoke", "--scheduler", "nonsense"], "scheduler"),
    (["run", "nothing-like-it"], "campaign"),
    (["run", "--resume"], "campaign"),
    (["run"], "campaign"),
])
def test_bad_options_are_one_line_errors(tmp_path, capsys, args, field):
    err = _one_line_error(capsys, ["campaign", *args, "--out", str(tmp_path / "o")])
    assert f"error: {field}=" in err
    assert not (tmp_path / "o").exists()


def test_status_of_a_folder_without_a_campaign(tmp_path, capsys):
    err = _one_line_error(capsys, ["campaign", "status", str(tmp_path)])
    assert "error: campaign=" in err


def test_builtins_share_the_structure_and_differ_in_budget():
    expanded = {name: expand(builtin(name)) for name in BUDGETS}
    shapes = {name: [(t["experiment"], t["kind"]) for t in tasks]
              for name, tasks in expanded.items()}
    assert set(map(str, [sorted(set(s)) for s in shapes.values()])) == {
        str(sorted(set(shapes["paper"])))}
    paper = {t["id"]: t for t in expanded["paper"]}
    assert paper["rq1/worm-s9"]["options"]["generations"] == 3000
    assert paper["rq1/worm-s9"]["options"]["population"] == 96
    assert paper["rq2-homo/worm-s9+s0-reopt"]["options"]["generations"] == 510
    assert sum(t["experiment"] == "rq1" for t in expanded["paper"]) == 20
    assert paper["ablation/biped-s0"]["options"]["representation"] == "weights"
    assert paper["omega-0.1/biped-s0"]["options"]["omega"] == 0.1


def test_tasks_follow_the_contract():
    tasks = expand(builtin("smoke"))
    seen = set()
    for task in tasks:
        assert task["id"] == task["path"] == f"{task['experiment']}/{task['id'].split('/')[1]}"
        assert all(need in seen for need in task["needs"])  # dependency order
        seen.add(task["id"])
        if task["kind"] in ("evolve", "reoptimize"):
            # every option of the run resolved: resolving again changes nothing
            own = {k: v for k, v in task["options"].items()
                   if k not in ("representation", "donors", "validation")}
            assert resolve(own).to_dict() == own
    by_id = {t["id"]: t for t in tasks}
    # the paper's pairs: back/legs of run i, front/torso of run i+1; heterogeneous: run i of
    # both shapes, the receiver's last module from the other shape's last
    assert by_id["rq2-homo/worm-s1+s0"]["options"]["donors"] == ["rq1/worm-s1", "rq1/worm-s0"]
    hetero = by_id["rq2-hetero/worm-s0+biped-s0"]["options"]
    assert hetero["donors"] == ["rq1/worm-s0", "rq1/biped-s0"]
    assert hetero["take"] == "back=DONOR1:back,front=DONOR2:torso"
    reopt = by_id["rq3-reassembly/biped-s0+s1-reopt"]
    assert reopt["options"]["start"] == "rq3-reassembly/biped-s0+s1"
    assert "rq3-discovery/biped-s0" in by_id["rq3-reassembly/biped-s0+s1"]["needs"]
    assert by_id["omega-reassembly/omega-10-worm-s0+s1-reopt"]["options"]["omega"] == 10.0


def test_begun_runs_start_before_new_ones_then_seed_by_seed(tmp_path):
    """Runs already begun go on first (a campaign grown by seeds finishes what it has), then
    the others seed by seed: every experiment's seed 0, then seed 1, ..., so that a campaign
    stopped part-way holds as many finished seeds of every experiment."""
    from somite.campaigns.executor import priorities

    tasks = [t for t in expand(builtin("paper-rq1")) if not t["id"].startswith("rq1/biped-s0")]
    order = [t["id"] for t in tasks]
    assert order.index("rq1/worm-s2") < order.index("ablation/biped-s0")  # the file's order
    fresh = priorities(tmp_path, tasks)
    assert sorted(fresh, key=fresh.get, reverse=True) == [
        "rq1/worm-s0", "ablation/biped-s0", "ablation/worm-s0",
        "rq1/biped-s1", "rq1/worm-s1", "ablation/biped-s1", "ablation/worm-s1",
        "rq1/biped-s2", "rq1/worm-s2", "ablation/biped-s2", "ablation/worm-s2"]
    for begun in ("ablation/worm-s0", "rq1/biped-s2", "rq1/worm-s1"):
        (tmp_path / begun).mkdir(parents=True)
    (tmp_path / "ablation" / "biped-s1").mkdir()
    grown = priorities(tmp_path, tasks)
    first = sorted(grown, key=grown.get, reverse=True)
    assert first == [
        "rq1/biped-s2", "rq1/worm-s1", "ablation/biped-s1", "ablation/worm-s0",  # begun
        "rq1/worm-s0", "ablation/biped-s0",
        "rq1/biped-s1", "ablation/worm-s1",
        "rq1/worm-s2", "ablation/biped-s2", "ablation/worm-s2"]
    assert sorted(grown.values()) == list(range(1, len(tasks) + 1))
    # rq1/ and ablation/ exist, yet rq1/worm-s0 waits above: an experiment's folder begins no
    # run; a run's own folder does.
    (tmp_path / "rq1" / "worm-s2").mkdir()
    again = priorities(tmp_path, tasks)
    assert again["rq1/worm-s2"] > again["rq1/worm-s0"]


def test_tasks_built_on_runs_belong_to_their_latest_seed(tmp_path):
    """A reassembly of seeds 9 and 0 can start only once seed 9 is done: it runs with seed 9,
    and its re-optimisation with it, though their own seed options say otherwise; submitted
    by priority, but never before a task it needs."""
    from somite.campaigns.executor import priorities, replicates, submission_order

    paper = expand(builtin("paper"))
    seeds = replicates(paper)
    assert seeds["rq1/worm-s3"] == 3 and seeds["rq3-discovery/worm-s3"] == 3
    assert seeds["rq2-homo/worm-s9+s0"] == 9 and seeds["rq2-homo/worm-s9+s0-reopt"] == 9
    assert seeds["rq2-homo/biped-s0+s1"] == 1
    by_id = {t["id"]: t for t in paper}
    assert by_id["rq2-homo/worm-s9+s0"]["options"]["seed"] == 0
    rank = priorities(tmp_path, paper)
    assert rank["rq2-homo/worm-s9+s0"] < min(rank[t["id"]] for t in paper
                                             if t["kind"] == "evolve" and seeds[t["id"]] < 9)
    assert rank["rq2-homo/worm-s9+s0"] < rank["rq1/worm-s9"]
    assert rank["rq2-homo/biped-s0+s1"] > rank["rq1/biped-s2"]
    smoke = expand(builtin("smoke"))
    (tmp_path / "rq2-homo" / "worm-s1+s0").mkdir(parents=True)
    submitted = [t["id"] for t in submission_order(smoke, priorities(tmp_path, smoke))]
    assert sorted(submitted) == sorted(t["id"] for t in smoke)
    for task in smoke:
        assert all(submitted.index(n) < submitted.index(task["id"]) for n in task["needs"])


def test_a_task_is_handed_out_when_a_thread_is_free_and_its_needs_have_run():
    """The campaign, not Dask, decides what starts next: at most as many tasks as free threads,
    the earliest in the campaign's order first, skipping over (not waiting behind) a task whose
    needs are still running; a task whose need failed, and the tasks built on it, never run."""
    from somite.campaigns.executor import Execution, skippable, startable

    def task(name, *needs):
        return {"id": name, "needs": list(needs)}

    a, b, c, d = task("a"), task("b"), task("c", "a"), task("d", "c")
    e, gone = task("e"), task("f", "finished-before")  # a need not in the campaign has run
    waiting = [a, b, c, d, e, gone]
    none = Execution()
    assert startable(waiting, none, 0) == [] and startable(waiting, none, -1) == []
    assert startable(waiting, none, 2) == [a, b]
    begun = Execution(started=["a", "b"])
    assert startable([c, d, e, gone], begun, 1) == [e]  # c waits for a, d for c
    assert startable([c, d, e, gone], begun, 5) == [e, gone]
    a_ran = Execution(started=["a", "b"], ran=["a"])
    assert startable([c, d, e], a_ran, 2) == [c, e]
    assert skippable([c, d, e], a_ran) == []
    a_failed = Execution(started=["a", "b"], failed={"a": "RuntimeError: boom"})
    assert startable([c, d, e], a_failed, 3) == [e]
    assert skippable([c, d, e], a_failed) == [c, d]


def test_variants_are_a_dimension_of_the_grid():
    campaign = parse({"defaults": {"generations": 5}, "experiments": {
        "w": {"kind": "evolve", "shapes": ["worm"], "seeds": [4, 5],
              "variants": {"strong": {"omega": 10.0}, "none": {}}},
        "r": {"kind": "reassemble", "donors": "w", "reoptimize": {"population": 6}},
    }}, name="mine", source="test")
    tasks = {t["id"]: t for t in expand(campaign)}
    assert tasks["w/strong-worm-s5"]["options"]["omega"] == 10.0
    assert tasks["w/none-worm-s5"]["options"]["omega"] == 1.0
    reopt = tasks["r/strong-worm-s5+s4-reopt"]["options"]
    assert (reopt["omega"], reopt["population"], reopt["generations"]) == (10.0, 6, 510)
    assert len(tasks) == 4 + 4 + 4


def test_list_counts_the_tasks(capsys):
    assert main(["campaign", "list"]) == 0
    out = capsys.readouterr().out
    for name in BUDGETS:
        row = next(line for line in out.splitlines() if f" {name} " in line)
        assert f" {len(expand(builtin(name)))} " in row


def test_a_folder_of_something_else_is_refused(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    err = _one_line_error(capsys, ["campaign", "run", "smoke", "--out", str(tmp_path)])
    assert "notes.txt" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_another_campaign_is_refused_and_the_same_needs_resume(tmp_path, capsys):
    from somite.campaigns.directory import document, prepare

    smoke = builtin("smoke")
    prepare(tmp_path, document(smoke, expand(smoke)), resume=False)
    err = _one_line_error(capsys, ["campaign", "run", "quick", "--resume", "--out",
                                   str(tmp_path)])
    assert "not this campaign's" in err
    err = _one_line_error(capsys, ["campaign", "run", "smoke", "--out", str(tmp_path)])
    assert "--resume" in err


def test_the_paper_grows_from_a_paper_rq1_folder_and_starts_with_rq1s_stages(tmp_path, capsys):
    """``paper:3`` over a ``paper-rq1`` folder keeps its 12 runs as they are and adds the rest
    (issue 67); the stages on those runs start first, then the omega runs seed by seed. A
    campaign that does not hold paper-rq1's tasks, or a file merely named ``paper``, does not
    grow it."""
    from somite.campaigns.directory import document, prepare, read
    from somite.campaigns.executor import priorities

    rq1 = builtin("paper-rq1")
    prepare(tmp_path, document(rq1, expand(rq1)), resume=False)
    before = read(tmp_path)["tasks"]
    paper = builtin("paper:3")
    grown = prepare(tmp_path, document(paper, expand(paper)), resume=True)
    assert read(tmp_path) == grown and grown["name"] == "paper" and len(grown["tasks"]) == 90
    assert [t for t in grown["tasks"] if t["experiment"] in ("rq1", "ablation")] == before
    left = [t for t in grown["tasks"] if t["experiment"] not in ("rq1", "ablation")]
    rank = priorities(tmp_path, left)
    first = sorted(rank, key=rank.get, reverse=True)
    experiments = [task_id.split("/")[0] for task_id in first]
    # discovery simulates nothing: it runs as soon as its run has, before any costly task
    assert experiments[:30] == ["rq3-discovery"] * 6 + ["rq2-homo"] * 12 + ["rq2-hetero"] * 12
    assert first[30:34] == ["omega-10/biped-s0", "omega-10/worm-s0", "omega-0.1/biped-s0",
                            "omega-0.1/worm-s0"]
    assert first.index("omega-10/biped-s1") > first.index("omega-0.1/worm-s0")

    for other, name, source in ((tmp_path / "two", "paper:2", None),
                                (tmp_path / "file", "paper", "paper.toml")):
        prepare(other, document(rq1, expand(rq1)), resume=False)
        campaign = builtin(name) if source is None else parse(
            BUILTINS["paper"](), name="paper", source=source)
        with pytest.raises(SomiteError, match="not this campaign's"):
            prepare(other, document(campaign, expand(campaign)), resume=True)
    assert main(["campaign", "run", "paper:x", "--out", str(tmp_path / "x")]) == 2
    assert "paper:N takes a count of seeds" in capsys.readouterr().err


def test_lengths_takes_a_count_of_seeds_as_a_campaign_of_its_own(tmp_path):
    """``lengths:N`` is the edge-length comparison at N seeds (issue 72): its evolve runs of
    seeds 0-2 are ``lengths``' own, its reassemblies pair each run with the next of N, so a
    folder of 3 seeds does not grow into it."""
    from somite.campaigns.directory import document, prepare

    three, four = builtin("lengths"), builtin("lengths:4")
    tasks3, tasks4 = expand(three), expand(four)
    assert (len(tasks3), len(tasks4)) == (54, 72)

    def evolve(tasks):
        return {t["id"]: t["options"] for t in tasks if t["kind"] == "evolve"}

    runs3, runs4 = evolve(tasks3), evolve(tasks4)
    assert len(runs4) == 24 and all(runs4[task] == options for task, options in runs3.items())
    assert {t["id"] for t in tasks4 if t["kind"] == "reassemble"} >= {
        "neutral-homo/worm-s2+s3", "length-delay-homo/biped-s3+s0"}
    prepare(tmp_path, document(three, expand(three)), resume=False)
    with pytest.raises(SomiteError, match="not this campaign's"):
        prepare(tmp_path, document(four, tasks4), resume=True)


def test_a_folder_of_a_builtin_made_before_its_experiments_were_reordered_resumes(tmp_path):
    """The paper structure's experiments were reordered (issue 67): a folder written in the
    old order holds the same tasks, so it resumes as it is, in its own order."""
    from somite.campaigns.directory import document, prepare

    smoke = builtin("smoke")
    doc = document(smoke, expand(smoke))
    before = ["rq1", "ablation", "omega-10", "omega-0.1", "rq2-homo", "rq2-hetero",
              "omega-reassembly", "rq3-discovery", "rq3-reassembly"]
    old = {**doc, "tasks": sorted(doc["tasks"], key=lambda t: before.index(t["experiment"]))}
    assert old["tasks"] != doc["tasks"]
    (tmp_path / "campaign.json").write_text(json.dumps(old))
    assert prepare(tmp_path, doc, resume=True)["tasks"] == old["tasks"]


# -- running on Dask ----------------------------------------------------------------------------

def _campaign_run(capsys, *args: str) -> None:
    """``somite campaign run ARGS --quiet`` in this process; it must succeed."""
    capsys.readouterr()
    assert main(["campaign", "run", *args, "--quiet"]) == 0, capsys.readouterr().err


def _logs(directory: Path) -> dict[str, list[dict]]:
    """Every file the tasks of a campaign wrote (but done.json), elapsed times aside."""
    found = {}
    for path in sorted(directory.rglob("*")):
        if not path.is_file() or path.name in ("done.json", ".somite.lock"):
            continue
        key = str(path.relative_to(directory))
        if path.name == "log.csv":
            rows = list(csv.DictReader(io.StringIO(path.read_text())))
            for row in rows:
                row.pop("elapsed_seconds")
            found[key] = rows
        elif path.name == "checkpoint.json":
            state = json.loads(path.read_text())
            state.pop("elapsed_seconds")
            found[key] = state
        elif path.name != "campaign.json":
            found[key] = path.read_text()
    return found


@pytest.fixture(scope="module")
def smoke_run(smoke_campaign) -> Path:
    """The smoke campaign on a LocalCluster of 2 workers of 1 thread (conftest's, run once for
    the suite: copy it before changing it)."""
    return smoke_campaign


def test_smoke_writes_every_task_folder(smoke_run, capsys):
    doc = json.loads((smoke_run / "campaign.json").read_text())
    assert doc["format"] == "somite-campaign" and doc["name"] == "smoke"
    assert set(doc["experiments"]) == {"rq1", "ablation", "omega-10", "omega-0.1", "rq2-homo",
                                       "rq2-hetero", "omega-reassembly", "rq3-discovery",
                                       "rq3-reassembly"}
    for task in doc["tasks"]:
        folder = smoke_run / task["path"]
        done = json.loads((folder / "done.json").read_text())
        assert done["task"] == task["id"] and done["elapsed_s"] >= 0
        assert OUTPUTS[task["kind"]] <= {p.name for p in folder.iterdir()}, task["id"]
        if task["kind"] in ("evolve", "reoptimize"):
            log = (folder / "log.csv").read_text().splitlines()
            assert len(log) == 2 + task["options"]["generations"]
            assert done["robot_control_steps"] > 0
            assert set(RUN_FILES) - {"transfer.csv"} <= {p.name for p in folder.iterdir()}
    assert not (smoke_run / ".somite.lock").exists()
    assert main(["campaign", "status", str(smoke_run)]) == 0
    out = capsys.readouterr().out
    assert f"{len(doc['tasks'])} done, 0 running, 0 partial, 0 queued" in out


def test_a_finished_campaign_resumes_to_nothing(smoke_run, capsys):
    before = {p: p.stat().st_mtime_ns for p in smoke_run.rglob("*") if p.is_file()}
    _campaign_run(capsys, "--resume", "--out", str(smoke_run))
    assert {p: p.stat().st_mtime_ns for p in smoke_run.rglob("*") if p.is_file()} == before


def test_a_retried_task_leaves_no_temporary_file_of_its_killed_attempt(smoke_run, tmp_path):
    """A task killed between write and rename leaves ``.NAME.PID.RAND.tmp``; redoing it must
    not keep that file beside the outputs (a killed campaign's resume once did)."""
    import shutil

    from somite.campaigns.work import run_task

    out = tmp_path / "smoke"
    shutil.copytree(smoke_run, out)
    task = next(t for t in json.loads((out / "campaign.json").read_text())["tasks"]
                if t["kind"] == "reassemble")
    folder = out / task["path"]
    (folder / "done.json").unlink()
    (folder / "reassembled.json").unlink()
    stale = folder / ".reassembled.json.4242.0123abcd.tmp"
    stale.write_text('{"format": "somite-genome"')  # half-written
    unrelated = folder / "notes.tmp"
    unrelated.write_text("mine")
    run_task(str(out), task)
    assert not stale.exists()
    assert unrelated.read_text() == "mine"  # only write_atomic's own temporary files go
    assert (folder / "done.json").is_file()
    assert _logs(folder) == _logs(smoke_run / task["path"]) | {"notes.tmp": "mine"}


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _wait(predicate, timeout: float = 600.0, every: float = 0.05):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(every)
    raise AssertionError("timed out waiting")


def test_a_scheduler_and_workers_started_by_hand_give_the_same_logs(smoke_run, tmp_path,
                                                                    capsys):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "dask"]
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    processes = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port",
                                   str(port), "--no-dashboard"], **quiet)]
    try:
        processes += [subprocess.Popen([*dask, "worker", address, "--nthreads", "1",
                                        "--no-dashboard"], cwd=tmp_path, **quiet)
                      for _ in range(2)]
        out = tmp_path / "smoke"
        _campaign_run(capsys, "smoke", "--out", str(out), "--scheduler", address)
    finally:
        for process in processes[::-1]:
            process.terminate()
        for process in processes:
            process.wait(timeout=30)
    assert _logs(out) == _logs(smoke_run)


LONG_RUN = """
[defaults]
generations = 30
population = 8
duration = 3.0
checkpoint_every = 4
validate_every = 30
[experiments.long]
kind = "evolve"
shapes = ["worm"]
seeds = [7]
"""


def test_a_killed_worker_is_replaced_and_its_run_resumes(tmp_path):
    spec = tmp_path / "long.toml"
    spec.write_text(LONG_RUN)
    out = tmp_path / "campaign"
    process = subprocess.Popen([*SOMITE, "campaign", "run", str(spec), "--out", str(out),
                                "--workers", "1", "--quiet"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    run = out / "long" / "worm-s7"

    def running_worker():
        try:
            rows = len((run / "log.csv").read_text().splitlines()) - 1
            holder = json.loads((run / ".somite.lock").read_text())
        except (OSError, ValueError):
            return None
        return holder["pid"] if (run / "checkpoint.json").exists() and rows >= 9 else None

    worker = _wait(running_worker)
    assert worker != process.pid  # the run is in a worker process, not the campaign's
    os.kill(worker, signal.SIGKILL)
    time.sleep(0.2)
    logged = (run / "log.csv").read_text().splitlines()
    checkpoint = json.loads((run / "checkpoint.json").read_text())["generation"]
    _, err = process.communicate(timeout=900)
    assert process.returncode == 0, err
    assert len(logged) - 1 < 31 and (run / "done.json").is_file()
    # Resumed from the checkpoint: the rows before it are those of the killed worker, its
    # elapsed times included.
    assert (run / "log.csv").read_text().splitlines()[:checkpoint + 2] == logged[:checkpoint + 2]
    # The same run, never interrupted, from the library.
    from somite.campaigns.work import run_config
    from somite.experiments.runner import evolve

    task = json.loads((out / "campaign.json").read_text())["tasks"][0]
    evolve(run_config(task["options"]), tmp_path / "direct")
    direct = _logs(tmp_path / "direct")
    resumed = _logs(run)
    assert resumed["log.csv"] == direct["log.csv"]
    assert resumed["bests.jsonl"] == direct["bests.jsonl"]


# -- on one cluster shared by the tests below ----------------------------------------------------
# A LocalCluster costs seconds of CPU to start, and seconds more for its workers to load the
# kernels: the tests that need a cluster, not one of their own, share one (started last in the
# module, so that it idles through no other test). The smoke campaign, a killed worker and the
# Ctrl-C test of test_user_campaigns.py start theirs as `campaign run` does.

@pytest.fixture(scope="module")
def cluster() -> str:
    """The scheduler address of a LocalCluster as ``campaign run`` starts one: 2 worker
    processes of 1 thread."""
    from somite.campaigns.executor import connect

    with connect(None, workers=2, threads=1) as connection:
        yield connection.cluster.scheduler_address


def test_a_campaign_grown_from_its_rq1_runs_ends_as_one_run_from_scratch(smoke_run, cluster,
                                                                          tmp_path, capsys):
    """The way ``paper:3`` grows from ``paper-rq1``'s folder, at the smoke budget: a folder
    holding only the finished RQ1 and ablation runs, resumed as the whole campaign, keeps
    those runs untouched and ends with the same files as the campaign run from scratch."""
    doc = json.loads((smoke_run / "campaign.json").read_text())
    kept = [t for t in doc["tasks"] if t["experiment"] in ("rq1", "ablation")]
    assert 0 < len(kept) < len(doc["tasks"])
    grown = tmp_path / "grown"
    for task in kept:
        shutil.copytree(smoke_run / task["path"], grown / task["path"])
    part = {**doc, "tasks": kept,
            "experiments": {k: v for k, v in doc["experiments"].items() if k in ("rq1", "ablation")}}
    (grown / "campaign.json").write_text(json.dumps(part))
    before = {p: p.stat().st_mtime_ns for p in grown.rglob("*") if p.is_file()}
    _campaign_run(capsys, "smoke", "--resume", "--out", str(grown), "--scheduler", cluster)
    assert json.loads((grown / "campaign.json").read_text())["tasks"] == doc["tasks"]
    assert all(p.stat().st_mtime_ns == t for p, t in before.items()
               if p.name != "campaign.json")
    assert _logs(grown) == _logs(smoke_run)


def _done(directory: Path) -> int:
    return len(list(directory.glob("*/*/done.json")))


def test_a_killed_campaign_resumes_to_the_same_logs(smoke_run, cluster, tmp_path, capsys):
    out = tmp_path / "smoke"
    process = subprocess.Popen([*SOMITE, "campaign", "run", "smoke", "--out", str(out),
                                "--workers", "2", "--quiet"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _wait(lambda: _done(out) >= 8 or process.poll() is not None)
    process.send_signal(signal.SIGKILL)
    process.wait()
    total = len(json.loads((out / "campaign.json").read_text())["tasks"])
    assert _done(out) < total  # killed mid-way
    _campaign_run(capsys, "--resume", "--out", str(out), "--scheduler", cluster)
    assert _done(out) == total
    assert _logs(out) == _logs(smoke_run)


TWO_EXPERIMENTS = """
[defaults]
generations = 2
population = 4
duration = 1.0
validate_every = 2
[experiments.first]
kind = "evolve"
shapes = ["worm"]
seeds = [0, 1]
[experiments.later]
kind = "evolve"
shapes = ["worm"]
seeds = [0]
"""


def test_a_resumed_campaign_finishes_its_begun_run_before_it_starts_new_ones(cluster, tmp_path,
                                                                             capsys):
    """On one worker, the run of the last experiment that had begun finishes before the
    campaign's first runs start (Dask hands a task to an idle worker as it is submitted, so
    priority alone would not do it)."""
    spec = tmp_path / "two.toml"
    spec.write_text(TWO_EXPERIMENTS)
    out = tmp_path / "campaign"
    _campaign_run(capsys, str(spec), "--out", str(out), "--scheduler", cluster)
    # The later run begun, the first ones never started; resumed on a cluster of its own.
    for seed in (0, 1):
        shutil.rmtree(out / "first" / f"worm-s{seed}")
    (out / "later" / "worm-s0" / "done.json").unlink()
    _campaign_run(capsys, "--resume", "--out", str(out), "--workers", "1", "--threads", "1")
    finished = {run: (out / run / "done.json").stat().st_mtime_ns
                for run in ("first/worm-s0", "first/worm-s1", "later/worm-s0")}
    assert sorted(finished, key=finished.get) == ["later/worm-s0", "first/worm-s0",
                                                  "first/worm-s1"]


ONE_LONG_RUN_AND_SHORT_ONES = """
[defaults]
generations = 1
population = 4
duration = 1.0
validate_every = 1
[experiments.long]
kind = "evolve"
shapes = ["worm"]
seeds = [0]
options = { generations = 16, duration = 4.0 }
[experiments.short]
kind = "evolve"
shapes = ["worm"]
seeds = [0, 1, 2, 3]
"""


def test_runs_start_in_the_campaigns_order_on_whichever_worker_frees_up(cluster, tmp_path,
                                                                         capsys):
    """Two workers, one long run and four short ones: the short runs start one after another,
    seed by seed, on the worker the long run leaves free (handed to Dask all at once, each
    would wait in one worker's queue, some behind the long run, while later seeds ran)."""
    spec = tmp_path / "order.toml"
    spec.write_text(ONE_LONG_RUN_AND_SHORT_ONES)
    out = tmp_path / "campaign"
    _campaign_run(capsys, str(spec), "--out", str(out), "--scheduler", cluster)

    def when(run, name):
        return (out / run / name).stat().st_mtime_ns

    short = [f"short/worm-s{seed}" for seed in range(4)]
    started = sorted(short, key=lambda run: when(run, "config.json"))
    assert started == short
    assert when(short[-1], "done.json") < when("long/worm-s0", "done.json")


def _closing_filters(dask_worker) -> int:
    import logging

    from somite.campaigns.executor import _Open

    handlers = logging.getLogger("distributed").handlers + logging.getLogger().handlers
    return sum(isinstance(f, _Open) for h in handlers for f in h.filters)


def test_a_restarted_local_worker_is_quiet_while_closing_too(cluster):
    """What a local worker logs once it is closing is not shown (a Ctrl-C on a loaded machine
    printed three tracebacks), on the workers a nanny starts again as on the first ones."""
    from distributed import Client

    with Client(cluster) as client:
        before = client.run(_closing_filters)
        client.restart()
        after = client.run(_closing_filters)
    assert len(after) == 2
    assert all(n > 0 for n in before.values()) and all(n > 0 for n in after.values())
