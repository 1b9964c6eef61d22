"""The committed pack of the running ``paper-rq1`` campaign (``reports/paper-rq1/``): it
unpacks, holds the built-in campaign's first tasks, and every run in it can resume under this
somite's physics. A change of the physics fails here first, not in the next session's resume:
the campaign's runs must not mix two kernels (issue 42), so such a change has to decide what
becomes of them (finish them on the old physics first, or restart them under the new one)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from somite.campaigns.builtin import builtin
from somite.campaigns.expansion import expand
from somite.cli import main
from somite.experiments.physics import ran_under, read
from somite.sim.version import PHYSICS

ROOT = Path(__file__).resolve().parents[1]
PACK = ROOT / "reports" / "paper-rq1" / "paper-rq1.pack"


@pytest.fixture(scope="module")
def unpacked(tmp_path_factory) -> Path:
    if not PACK.is_file():
        pytest.skip("no committed paper-rq1 pack")
    out = tmp_path_factory.mktemp("paper-rq1") / "campaign"
    assert main(["campaign", "unpack", str(PACK), "--out", str(out), "--quiet"]) == 0
    return out


def test_the_pack_is_the_builtin_campaign_in_its_order(unpacked):
    tasks = [t["id"] for t in json.loads((unpacked / "campaign.json").read_text())["tasks"]]
    whole = [t["id"] for t in expand(builtin("paper-rq1"))]
    assert set(tasks) <= set(whole)
    assert sorted(tasks, key=whole.index) == tasks
    assert {"rq1/biped-s0", "rq1/worm-s0", "ablation/biped-s0", "ablation/worm-s0"} <= set(tasks)


def test_every_started_run_resumes_under_this_physics(unpacked):
    started = [p.parent for p in unpacked.glob("*/*/physics.json")]
    assert started, "the pack holds no started run"
    for run in started:
        assert ran_under(read(run)) == PHYSICS, (
            f"{run.relative_to(unpacked)} ran under {ran_under(read(run))}, this somite's "
            f"physics is {PHYSICS}: reports/paper-rq1/README.md")


def test_every_started_run_has_a_checkpoint_at_its_last_logged_generations(unpacked):
    for run in (p.parent for p in unpacked.glob("*/*/physics.json")):
        with open(run / "log.csv", newline="") as handle:
            last = int(list(csv.DictReader(handle))[-1]["generation"])
        checkpoint = json.loads((run / "checkpoint.json").read_text())
        config = json.loads((run / "config.json").read_text())
        assert 0 <= last - checkpoint["generation"] <= config["checkpoint_every"], run.name
        assert (config["generations"], config["population"]) == (3000, 96)
