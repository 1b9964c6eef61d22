"""Work that would not finish, or not fit, is refused before it starts (``--yes`` for long
work; memory never), and the paper's own sizes pass."""

from __future__ import annotations

import pytest

from somite import budget
from somite.cli import main
from somite.commands.common import check_run_work
from somite.experiments.config import resolve


def test_the_papers_run_passes_and_its_time_is_bench_s():
    config = resolve({})  # 96 x 3000 generations of 30 s, parents re-evaluated
    check_run_work(config, 12, yes=False)
    # 1.04e9 robot-control-steps at 100,000 a second on 2 cores.
    assert budget.hours(1.04e9) == pytest.approx(1.04e9 / 100_000 / 3600)
    assert budget.hours(1e6, voxels=120) == pytest.approx(10 * budget.hours(1e6))


@pytest.mark.parametrize("argv", [
    ["evolve", "--shape", "32x32", "--population", "10000", "--duration", "600"],
    ["evolve", "--population", "10000", "--evaluations", "1000"],
    ["evolve", "--generations", "20000"],
    ["bench", "--robots", "10000", "--duration", "600", "--shapes", "32x32"],
    ["campaign", "run", "paper"],
])
def test_long_work_needs_yes(tmp_path, capsys, argv):
    assert main([*argv, "--out", str(tmp_path / "x")] if argv[0] != "bench" else argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "give --yes to start it anyway" in err, err
    assert not (tmp_path / "x").exists()


def test_memory_is_refused_even_with_yes(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(budget, "machine_memory", lambda: 8 * 2**30)
    assert main(["bench", "--robots", "10000", "--duration", "0.1", "--shapes", "32x32",
                 "--yes"]) == 2
    err = capsys.readouterr().err
    assert "a batch of 10000 robots of 1024 voxels needs more than half" in err


def test_a_drawing_is_checked_before_it_is_simulated(tmp_path, capsys, monkeypatch):
    run = tmp_path / "run"
    assert main(["evolve", "--population", "4", "--generations", "0", "--duration", "1",
                 "--out", str(run), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["show", str(run), "--duration", "600", "--fps", "60", "--width", "8192",
                 "--height", "8192", "--out", str(tmp_path / "w.mp4")]) == 2
    assert "give --yes" in capsys.readouterr().err
    monkeypatch.setattr(budget, "machine_memory", lambda: 6 * 2**30)
    assert main(["show", str(run), "--frames", "1000", "--width", "8192", "--height", "8192",
                 "--out", str(tmp_path / "s.png")]) == 2
    assert "the 1000 frames of s.png needs more than half" in capsys.readouterr().err
    assert main(["show", str(run), "--duration", "60", "--out", str(tmp_path / "w.gif")]) == 2
    assert "the 1800 frames of w.gif" in capsys.readouterr().err
    assert not any((tmp_path / name).exists() for name in ("w.mp4", "s.png", "w.gif"))
