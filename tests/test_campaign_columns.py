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
