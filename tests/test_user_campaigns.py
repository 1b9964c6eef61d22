"""A campaign file of one's own, before, during and after it runs: the user guide's file
declares the report's figures it feeds, ``campaign list FILE`` sizes it before it runs, Ctrl-C
stops it in one line, and the transfer table flags ratios over a speed near zero."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from somite.campaigns import figures
from somite.campaigns.expansion import expand
from somite.campaigns.spec import load
from somite.cli import main
from somite.report.markdown import _transfer
from somite.report.transfer import NEAR_ZERO, read_transfer

from .test_readme import _block

SOMITE = [sys.executable, "-m", "somite.cli"]


@pytest.fixture
def guide_campaign(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(_block("campaign-file", "toml"))
    return path


def test_the_guides_campaign_file_declares_the_figures_of_its_groups(guide_campaign):
    campaign = load(guide_campaign)
    declared = figures.declared({e.name: e.figures for e in campaign.experiments})
    variants = {e.name: len(e.settings.get("variants") or {}) or 1
                for e in campaign.experiments if e.kind == "evolve"}
    missing = figures.missing(declared, variants)
    # base's two variants are Figure 5's two groups; swap's re-optimisations are Figure 7
    assert {"figure3", "figure5", "figure7"} <= set(declared)
    assert not {"figure3", "figure5", "figure7"} & set(missing)


def test_a_third_group_in_figure5_is_refused_naming_the_experiment(guide_campaign, capsys):
    text = guide_campaign.read_text().replace(
        "[experiments.swap]", '[experiments.more]\nkind = "evolve"\nshapes = ["worm"]\n'
        'seeds = 1\nfigures = { figure5 = "" }\n[experiments.swap]')
    guide_campaign.write_text(text)
    assert main(["campaign", "list", str(guide_campaign)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "experiments.more.figures.figure5" in err


def test_campaign_list_sizes_a_file_before_it_runs(guide_campaign, capsys):
    assert main(["campaign", "list", str(guide_campaign), "smoke"]) == 0
    out = capsys.readouterr().out
    tasks = expand(load(guide_campaign))
    row = next(line for line in out.splitlines() if line.lstrip().startswith(
        str(guide_campaign)[:8]))
    assert f" {len(tasks)} " in row and "e+0" in row  # tasks, robot-control-steps, time
    assert any(line.lstrip().startswith("smoke ") for line in out.splitlines())
    assert main(["campaign", "list", str(guide_campaign.with_name("none.toml"))]) == 2
    assert "campaign=" in capsys.readouterr().err


def test_ctrl_c_on_a_running_campaign_prints_one_line(tmp_path):
    # A terminal's Ctrl-C reaches every process of its group, Dask's workers too.
    spec = tmp_path / "long.toml"
    spec.write_text('[defaults]\npopulation = 4\nduration = 1.0\n[experiments.a]\n'
                    'kind = "evolve"\nshapes = ["worm"]\nseeds = 2\n'
                    'options = { generations = 100000 }\n')
    out = tmp_path / "c"
    process = subprocess.Popen([*SOMITE, "campaign", "run", str(spec), "--out", str(out),
                                "--workers", "2", "--threads", "1", "--quiet", "--yes"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        deadline = time.monotonic() + 600
        # Its workers run once a run has begun its folder.
        while not list(out.glob("a/*/config.json")) and process.poll() is None:
            assert time.monotonic() < deadline, "the campaign did not start"
            time.sleep(0.5)
        os.killpg(process.pid, signal.SIGINT)
        stdout, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130
    assert stderr == "somite campaign: interrupted\n" and stdout == ""


def test_the_transfer_table_flags_ratios_over_a_speed_near_zero(tmp_path):
    (tmp_path / "transfer.csv").write_text(
        "task,engine,sensors,generation,somite_vx,vsr_vx,ratio,somite_own_vx,overall_ratio\n"
        "a/worm-s0,stock,code,10,2.0,1.8,0.9,3.0,0.6\n"
        "a/worm-s1,stock,code,10,0.02,-2.16,-108.0,0.4,-5.4\n")
    data = read_transfer(tmp_path, {"a/worm-s0": ("a", "worm"), "a/worm-s1": ("a", "worm")})
    flags = [(r["ratio_near_zero"], r["overall_near_zero"]) for r in data["rows"]]
    assert flags == [(False, False), (True, True)] and NEAR_ZERO > 0.4
    assert data["summary"][0]["near_zero"] == 1
    text = "\n".join(_transfer({"transfer": data}))
    assert "-108.000 (*near 0*)" in text and "0.900 (*near 0*)" not in text
    assert "A ratio marked *near 0*" in text
