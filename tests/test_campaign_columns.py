"""``somite campaign status`` and ``campaign list`` at 80 columns: every cell whole, no line
wider than the terminal. The campaign directory is a built-in's ``campaign.json`` with a few
task folders written by hand (a log, a lock, done.json): no task runs."""

from __future__ import annotations

import json
import os
import re
import socket
from pathlib import Path

import pytest

from somite.budget import STEPS_PER_CORE_SECOND, about
from somite.campaigns.builtin import BUDGETS, builtin
from somite.campaigns.directory import document, prepare
from somite.campaigns.executor import cores
from somite.campaigns.expansion import expand
from somite.campaigns.kinds import estimate
from somite.campaigns.progress import states
from somite.cli import main
from somite.experiments.lock import LOCK_NAME
from somite.experiments.logfile import LOG_COLUMNS, format_row

WIDTH = 80
LONGEST = "omega-reassembly/omega-0.1-biped-s0+s1-reopt"
"""The built-ins' longest task id (44 characters)."""


def _log(folder: Path, rows: list[tuple[int, float, float | None]]) -> None:
    """A run's log.csv: (generation, best v_x, validation v_x) a row."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = [",".join(LOG_COLUMNS)]
    for generation, best, validation in rows:
        row = dict.fromkeys(LOG_COLUMNS)
        row.update(generation=generation, best_velocity=best, validation_velocity=validation)
        lines.append(format_row(row))
    (folder / "log.csv").write_text("\n".join(lines) + "\n")


def _done(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "done.json").write_text(json.dumps({"robot_control_steps": 0}))


def _campaign(root: Path, name: str) -> Path:
    """The built-in ``name`` laid out: one run done, one running, one stopped part-way, one
    reassembly done; every other task queued."""
    campaign = builtin(name)
    prepare(root, document(campaign, expand(campaign)), resume=False)
    generations = BUDGETS[name]["defaults"]["generations"]
    _log(root / "rq1/biped-s0", [(0, 0.05, 0.01), (generations, 0.123, 0.045)])
    _done(root / "rq1/biped-s0")
    _log(root / "rq1/worm-s0", [(0, -0.02, None), (1, -0.005, None)])
    (root / "rq1/worm-s0" / LOCK_NAME).write_text(json.dumps(
        {"pid": os.getpid(), "host": socket.gethostname()}))
    _log(root / LONGEST, [(0, 1.5, 0.75)])
    _done(root / "rq2-homo/worm-s0+s1")
    (root / "rq2-homo/worm-s0+s1/report.json").write_text(json.dumps(
        {"validation": {"v_reassembled": 0.25}}))
    return root


def _output(capsys, monkeypatch, argv: list[str], width: int = WIDTH) -> str:
    monkeypatch.setenv("COLUMNS", str(width))
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "…" not in out
    assert max(len(line) for line in out.splitlines()) <= width
    return out


def _fmt(value) -> str:
    return "-" if value is None else f"{value:.3f}"


def _expected(root: Path) -> dict[str, list[str]]:
    """Every task's cells, from what the disk says of it."""
    doc = json.loads((root / "campaign.json").read_text())
    cells = {}
    for info in states(root, doc):
        generation = "-"
        if info["generations"] is not None:
            reached = "-" if info["generation"] is None else info["generation"]
            generation = f"{reached}/{info['generations']}"
        cells[info["id"]] = [info["kind"], info["state"], generation, _fmt(info["best"]),
                             _fmt(info["validation"])]
    return cells


def _rows(out: str) -> dict[str, list[str]]:
    """The compact table's rows by task id: each name follows its experiment's row
    (``rq1/``), and is whole on its line; the counts' line follows the table."""
    lines = out.splitlines()
    body = lines[next(i for i, line in enumerate(lines) if line.startswith("─")) + 1:]
    rows, experiment = {}, None
    for line in body:
        words = line.split()
        if re.match(r"\d+ done, ", line):
            break
        if len(words) == 1 and words[0].endswith("/"):
            experiment = words[0]
            continue
        assert len(words) == 6, f"a row cut or folded: {line!r}"
        rows[experiment + words[0]] = words[1:]
    return rows


@pytest.mark.parametrize("name", ["smoke", "paper"])
def test_status_shows_every_cell_at_80_columns(tmp_path, capsys, monkeypatch, name):
    root = _campaign(tmp_path / name, name)
    out = _output(capsys, monkeypatch, ["campaign", "status", str(root)])
    expected = _expected(root)
    assert _rows(out) == expected
    generations = BUDGETS[name]["defaults"]["generations"]
    assert expected["rq1/biped-s0"] == ["evolve", "done", f"{generations}/{generations}",
                                        "0.123", "0.045"]
    assert expected["rq1/worm-s0"] == ["evolve", "running", f"1/{generations}", "-0.005", "-"]
    assert expected[LONGEST][:2] == ["reoptimize", "partial"]
    assert expected[LONGEST][3:] == ["1.500", "0.750"]
    assert expected["rq2-homo/worm-s0+s1"] == ["reassemble", "done", "-", "-", "0.250"]
    assert f"{len(expected) - 4} queued" in out
    # First the discoveries of the finished run and of the running one (they simulate
    # nothing), then seed 0's last run: the partial re-optimisation waits for the runs it needs.
    following = re.search(r"next to start: (\S+), (\S+), (\S+) and (\d+) more",
                          " ".join(out.split()))
    assert following.group(1, 2, 3) == ("rq3-discovery/biped-s0", "rq3-discovery/worm-s0",
                                        "ablation/biped-s0")
    assert int(following.group(4)) == len(expected) - 3 - 3  # two done, one running
    # The unit whole on its own line, however narrow the table (it once wrapped mid-phrase).
    assert "v_x in m/s" in [line.strip() for line in out.splitlines()]


def test_status_keeps_whole_ids_where_they_fit(tmp_path, capsys, monkeypatch):
    root = _campaign(tmp_path / "smoke", "smoke")
    out = _output(capsys, monkeypatch, ["campaign", "status", str(root)], width=200)
    for task_id, cells in _expected(root).items():
        assert any(line.split("│")[1:-1] and [c.strip() for c in line.split("│")[1:-1]]
                   == [task_id, *cells] for line in out.splitlines()), task_id


def test_list_shows_every_cell_and_a_time_at_80_columns(capsys, monkeypatch):
    out = _output(capsys, monkeypatch, ["campaign", "list"])
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines()
            if line.split() and line.split()[0] in BUDGETS}
    assert set(rows) == set(BUDGETS)
    for name in BUDGETS:
        tasks = expand(builtin(name))
        kinds = [str(sum(t["kind"] == k for t in tasks))
                 for k in ("evolve", "reassemble", "reoptimize", "discover")]
        steps = sum(estimate(t) for t in tasks)
        time = about(steps / (STEPS_PER_CORE_SECOND * cores()))
        assert rows[name] == [str(len(tasks)), *kinds, f"{steps:.2e}", *time.split()], name
    for header in ("campaign", "tasks", "evolve", "reassemble", "reoptimize", "discover",
                   "robot-", "control-", "steps", "time on", f"{cores()} cores"):
        assert header in out
    assert f"{STEPS_PER_CORE_SECOND:,} robot-control-steps/s a core" in " ".join(out.split())


def test_a_time_is_short():
    assert [about(s) for s in (2.3, 600, 13_125, 2.55e6, 1e9)] == [
        "~2 s", "~10 min", "~3.6 h", "~30 days", "~32 years"]


def test_status_shows_the_last_validation_the_log_measured(tmp_path):
    """A run validates every few generations: its status is the last validation v_x, not the
    last row's empty cell; a log's tail cut inside a row gives only whole rows."""
    from somite.campaigns.kinds.common import log_tail
    from somite.campaigns.kinds.evolve import progress

    rows = [(g, 0.01 * g, 0.5 * g if g % 50 == 0 else None) for g in range(121)]
    _log(tmp_path / "run", rows)
    assert progress(tmp_path / "run", {}, False) == {
        "generation": 120, "best": 1.2, "validation": 50.0}
    for size in range(100, 140):  # cut anywhere in a row, the first row read is whole
        tail = log_tail(tmp_path / "run" / "log.csv", size)
        assert 0 < len(tail) < 10 and [int(r["generation"]) for r in tail] == list(
            range(121 - len(tail), 121))
        assert all(float(r["best_velocity"]) == 0.01 * int(r["generation"]) for r in tail)
    _log(tmp_path / "fresh", rows[1:3])
    assert progress(tmp_path / "fresh", {}, False)["validation"] is None


def test_status_and_origin_read_the_same_last_validation(tmp_path):
    """One reader of a log's last validation: the status shows a NaN as measured (the latest
    best's episode went non-finite), and a module's reference speed is then unknown rather
    than an earlier best's."""
    import math

    from somite.campaigns.kinds.evolve import progress
    from somite.experiments.origin import _last_validation

    rows = [(0, 0.1, 0.2), (50, 0.3, 0.4), (51, 0.3, None)]
    _log(tmp_path / "run", rows)
    assert progress(tmp_path / "run", {}, False)["validation"] == 0.4
    assert _last_validation(tmp_path / "run") == 0.4
    _log(tmp_path / "run", [*rows, (100, 0.5, float("nan")), (101, 0.5, None)])
    assert math.isnan(progress(tmp_path / "run", {}, False)["validation"])
    assert _last_validation(tmp_path / "run") is None


def _timed_log(folder: Path, paces: list[tuple[int, float]]) -> None:
    """A run's log.csv whose generations after the 0th (3 s) took the given seconds:
    (generations, seconds each), in order."""
    folder.mkdir(parents=True, exist_ok=True)
    rows, generation, elapsed = [(0, 3.0)], 0, 3.0
    for count, seconds in paces:
        for _ in range(count):
            generation, elapsed = generation + 1, elapsed + seconds
            rows.append((generation, elapsed))
    lines = [",".join(LOG_COLUMNS)]
    for generation, elapsed in rows:
        row = dict.fromkeys(LOG_COLUMNS)
        row.update(generation=generation, best_velocity=0.5, elapsed_seconds=elapsed)
        lines.append(format_row(row))
    (folder / "log.csv").write_text("\n".join(lines) + "\n")


def test_a_run_s_pace_is_its_last_hundred_generations(tmp_path):
    """Timed from elapsed_seconds (a run's own computing, kept across resumes): the last 100
    generations, so that a run's first compile or a busier machine long ago do not count."""
    from somite.campaigns.kinds.evolve import PACE_GENERATIONS, progress

    _timed_log(tmp_path / "run", [(200, 9.0), (150, 6.0)])
    found = progress(tmp_path / "run", {}, False)
    assert found["generation"] == 350 and PACE_GENERATIONS == 100
    assert found["seconds_per_generation"] == pytest.approx(6.0)
    _timed_log(tmp_path / "slow-end", [(200, 6.0), (30, 9.0)])
    assert progress(tmp_path / "slow-end", {}, False)["seconds_per_generation"] == (
        pytest.approx((70 * 6.0 + 30 * 9.0) / 100))
    _log(tmp_path / "untimed", [(0, 0.1, None), (1, 0.2, None)])
    assert "seconds_per_generation" not in progress(tmp_path / "untimed", {}, False)
    _timed_log(tmp_path / "one-row", [])
    assert "seconds_per_generation" not in progress(tmp_path / "one-row", {}, False)


def test_status_says_the_time_left_at_the_runs_pace(tmp_path, capsys, monkeypatch):
    """paper-rq1:1 (four runs of 3000 generations, the same robot-control-steps each): one run
    done at 4 s a generation, two running at 6 and 5 s, one queued at the median pace (5 s):
    2000 x 6 + 2900 x 5 + 3000 x 5 = 41,500 s one run at a time, half that two at a time
    (4100 of the 12,000 generations done: 34.2%)."""
    from somite.campaigns.progress import seconds_left

    root = tmp_path / "rq1"
    campaign = builtin("paper-rq1:1")
    prepare(root, document(campaign, expand(campaign)), resume=False)
    doc = json.loads((root / "campaign.json").read_text())
    assert [t["id"] for t in doc["tasks"]] == [
        "rq1/biped-s0", "rq1/worm-s0", "ablation/biped-s0", "ablation/worm-s0"]
    _timed_log(root / "rq1/biped-s0", [(3000, 4.0)])
    _done(root / "rq1/biped-s0")
    _timed_log(root / "rq1/worm-s0", [(900, 8.0), (100, 6.0)])
    _timed_log(root / "ablation/biped-s0", [(100, 5.0)])
    for run in ("rq1/worm-s0", "ablation/biped-s0"):
        (root / run / LOCK_NAME).write_text(json.dumps(
            {"pid": os.getpid(), "host": socket.gethostname()}))
    assert seconds_left(doc, states(root, doc)) == pytest.approx(41_500)
    out = " ".join(_output(capsys, monkeypatch, ["campaign", "status", str(root)]).split())
    assert ("1 done, 2 running, 0 partial, 1 queued; 34.2% of 4.15e+09 robot-control-steps; "
            "left at the runs' recent pace: ~11.5 h one task at a time, ~5.8 h 2 at a time"
            ) in out
    assert out.endswith("next to start: ablation/worm-s0")
    # Stopped, the same time left, one task at a time only; finished, no estimate at all.
    for run in ("rq1/worm-s0", "ablation/biped-s0"):
        (root / run / LOCK_NAME).unlink()
    out = " ".join(_output(capsys, monkeypatch, ["campaign", "status", str(root)]).split())
    assert out.endswith("left at the runs' recent pace: ~11.5 h one task at a time next to "
                        "start: rq1/worm-s0, ablation/biped-s0, ablation/worm-s0")
    for run in ("rq1/worm-s0", "ablation/biped-s0", "ablation/worm-s0"):
        _done(root / run)
    out = _output(capsys, monkeypatch, ["campaign", "status", str(root)])
    assert "left at" not in out and seconds_left(doc, states(root, doc)) == 0
    assert "next to start" not in out
