"""The committed packs of the paper's campaigns: ``paper-rq1`` (``reports/paper-rq1/``,
finished) and ``paper`` at 3 seeds (``reports/paper/``, grown from it, running): each unpacks,
holds its built-in campaign's tasks in their order, and every run in it can resume under this
somite's physics; the grown one holds paper-rq1's runs byte for byte. A change of the physics fails here first, not in the next session's resume:
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
PACKS = {"paper-rq1": PACK, "paper:3": ROOT / "reports" / "paper" / "paper.pack"}
"""Each committed pack, by the built-in campaign it holds."""


def _unpack(pack: Path, out: Path) -> Path:
    if not pack.is_file():
        pytest.skip(f"no committed pack {pack.relative_to(ROOT)}")
    assert main(["campaign", "unpack", str(pack), "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="module", params=list(PACKS))
def unpacked(request, tmp_path_factory) -> tuple[str, Path]:
    name = request.param
    out = tmp_path_factory.mktemp(name.replace(":", "-")) / "campaign"
    return name, _unpack(PACKS[name], out)


def test_the_pack_is_the_builtin_campaign_in_its_order(unpacked):
    name, folder = unpacked
    tasks = [t["id"] for t in json.loads((folder / "campaign.json").read_text())["tasks"]]
    whole = [t["id"] for t in expand(builtin(name))]
    assert set(tasks) <= set(whole)
    assert sorted(tasks, key=whole.index) == tasks
    assert {"rq1/biped-s0", "rq1/worm-s0", "ablation/biped-s0", "ablation/worm-s0"} <= set(tasks)


def test_every_started_run_resumes_under_this_physics(unpacked):
    _, folder = unpacked
    started = [p.parent for p in folder.glob("*/*/physics.json")]
    assert started, "the pack holds no started run"
    for run in started:
        assert ran_under(read(run)) == PHYSICS, (
            f"{run.relative_to(folder)} ran under {ran_under(read(run))}, this somite's "
            f"physics is {PHYSICS}: reports/paper-rq1/README.md")


def test_every_started_run_has_a_checkpoint_at_its_last_logged_generations(unpacked):
    _, folder = unpacked
    options = {t["id"]: t["options"]
               for t in json.loads((folder / "campaign.json").read_text())["tasks"]}
    for run in (p.parent for p in folder.glob("*/*/physics.json")):
        with open(run / "log.csv", newline="") as handle:
            last = int(list(csv.DictReader(handle))[-1]["generation"])
        checkpoint = json.loads((run / "checkpoint.json").read_text())
        config = json.loads((run / "config.json").read_text())
        assert 0 <= last - checkpoint["generation"] <= config["checkpoint_every"], run.name
        task = options[run.relative_to(folder).as_posix()]
        assert (config["generations"], config["population"]) == (
            task["generations"], task["population"])
        assert config["population"] == 96 and config["generations"] in (3000, 510)


def test_the_grown_pack_holds_paper_rq1s_runs_byte_for_byte(tmp_path):
    """``paper:3`` grew from paper-rq1's folder (issue 67): its 12 RQ1 and ablation runs are
    paper-rq1's, not computed again."""
    grown = _unpack(PACKS["paper:3"], tmp_path / "paper")
    rq1 = _unpack(PACK, tmp_path / "paper-rq1")
    runs = sorted(p.parent.relative_to(rq1) for p in rq1.glob("*/*/done.json"))
    assert len(runs) == 12
    for run in runs:
        for name in ("log.csv", "best.json", "done.json", "config.json"):
            assert (grown / run / name).read_bytes() == (rq1 / run / name).read_bytes(), run
