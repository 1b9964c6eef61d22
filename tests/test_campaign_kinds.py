"""The campaign task kinds' registry, every entry checked alike (as Gymnasium runs its checker
over every registered environment); experiments declaring their figures; the built-in
``paper-rq1`` at the paper's settings. Nothing here runs a task."""

from __future__ import annotations

import json

import pytest

from somite.campaigns import figures
from somite.campaigns.builtin import BUDGETS, BUILTINS, RQ1_SEEDS, builtin
from somite.campaigns.directory import check_runnable, document, prepare, state
from somite.campaigns.expansion import expand
from somite.campaigns.kinds import EXPERIMENT_KINDS, TASK_KINDS, estimate
from somite.campaigns.kinds.evolve import run_steps
from somite.campaigns.spec import parse
from somite.cli import main
from somite.errors import SomiteError

TINY = {"defaults": {"generations": 1, "population": 4, "duration": 1.0},
        "experiments": {
            "runs": {"kind": "evolve", "shapes": ["worm"], "seeds": 2},
            "cut": {"kind": "reassemble", "donors": "runs", "reoptimize": {"generations": 1}},
            "found": {"kind": "discover", "genomes": "runs"}}}
MADE_BY = dict.fromkeys(("evolve", "reassemble", "reoptimize", "discover"), TINY)
"""A campaign that makes tasks of each kind (a new kind adds its own here)."""


def test_every_kind_has_a_campaign_that_makes_it():
    assert set(MADE_BY) == set(TASK_KINDS)


def _tasks_of(name: str) -> list[dict]:
    campaign = parse(MADE_BY[name], "tiny", "test")
    tasks = expand(campaign)
    check_runnable(document(campaign, tasks))
    return [t for t in tasks if t["kind"] == name]


@pytest.mark.parametrize("name", list(TASK_KINDS))
def test_every_kind_is_made_checked_and_estimated_by_its_entry(name):
    """Each kind's tasks pass its check, and its estimate is a whole number of
    robot-control-steps (a run's: its run_steps)."""
    tasks = _tasks_of(name)
    assert tasks, f"no {name} task made"
    for task in tasks:
        steps = estimate(task)
        assert isinstance(steps, int) and steps >= 0
        if "best.json" in TASK_KINDS[name].outputs:
            assert steps == run_steps(task["options"]) > 0


@pytest.mark.parametrize("name", list(TASK_KINDS))
def test_every_kind_reads_a_missing_folder_as_one_line(tmp_path, name):
    """A finished task whose files are gone is unreadable (the report shows it missing), and
    a queued one has no progress: an error or nothing, never a traceback."""
    task = _tasks_of(name)[0]
    with pytest.raises(SomiteError) as error:
        TASK_KINDS[name].read(tmp_path / "gone", task["options"])
    assert "\n" not in str(error.value)
    assert state(tmp_path, task)["state"] == "queued"
    assert TASK_KINDS[name].progress(tmp_path / "gone", task["options"], False) == {}


@pytest.mark.parametrize("name", list(TASK_KINDS))
def test_every_kind_has_a_column_in_campaign_list(capsys, monkeypatch, name):
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["campaign", "list"]) == 0
    header = next(line for line in capsys.readouterr().out.splitlines() if "campaign" in line
                  and "tasks" in line)
    assert name in header.split()


def test_a_kind_without_an_experiment_is_refused_as_one():
    assert set(EXPERIMENT_KINDS) == {k for k, v in TASK_KINDS.items() if v.expand is not None}
    assert "reoptimize" not in EXPERIMENT_KINDS  # made by a reassemble experiment
    with pytest.raises(SomiteError, match=r"experiments\.a\.kind='reoptimize'"):
        parse({"experiments": {"a": {"kind": "reoptimize"}}}, "x", "test")


# -- paper-rq1 -------------------------------------------------------------------------------

def test_paper_rq1_is_rq1_and_the_ablation_at_the_papers_settings():
    tasks = expand(builtin("paper-rq1"))
    assert RQ1_SEEDS == 3
    assert [t["id"] for t in tasks] == [f"{e}/{s}-s{i}" for e in ("rq1", "ablation")
                                        for s in ("biped", "worm") for i in range(3)]
    assert {t["kind"] for t in tasks} == {"evolve"}
    for task in tasks:
        options = task["options"]
        assert (options["generations"], options["population"], options["duration"],
                options["transient"], options["terrain"], options["reevaluate_parents"],
                options["evaluations"]) == (3000, 96, 30.0, 5.0, "hilly-1-10-rnd", True, 1)
        assert options["weights_only"] == (task["experiment"] == "ablation")
        assert options["representation"] == ("weights" if options["weights_only"] else "graph")
    # The very runs of the paper campaign, so either's runs stand for the other's.
    paper = {t["id"]: t for t in expand(builtin("paper"))}
    assert all(paper[t["id"]] == t for t in tasks)
    assert builtin("paper-rq1").validation == BUDGETS["paper"]["validation"]


def test_paper_rq1_takes_more_seeds_and_resumes_with_them(tmp_path):
    three, ten = builtin("paper-rq1"), builtin("paper-rq1:10")
    small, large = expand(three), expand(ten)
    assert len(large) == 40 and all(t in large for t in small)
    prepare(tmp_path, document(three, small), resume=False)
    grown = prepare(tmp_path, document(ten, large), resume=True)
    assert grown["tasks"] == large
    assert json.loads((tmp_path / "campaign.json").read_text())["tasks"] == large
    # Fewer seeds than the directory holds are not this campaign.
    with pytest.raises(SomiteError, match="not this campaign's"):
        prepare(tmp_path, document(three, small), resume=True)
    with pytest.raises(SomiteError, match="campaign='paper-rq1:x'"):
        builtin("paper-rq1:x")
    with pytest.raises(SomiteError, match="campaign='quick:3'"):
        builtin("quick:3")


def test_campaign_list_gives_paper_rq1_and_its_cost(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["campaign", "list"]) == 0
    out = capsys.readouterr().out
    rows = {line.split("│")[1].strip(): [c.strip() for c in line.split("│")[2:-1]]
            for line in out.splitlines() if line.count("│") > 3}
    assert set(rows) == set(BUILTINS)
    tasks = expand(builtin("paper-rq1"))
    counts = [str(sum(t["kind"] == k for t in tasks)) for k in TASK_KINDS]
    steps = sum(estimate(t) for t in tasks)
    assert rows["paper-rq1"][:len(TASK_KINDS) + 2] == ["12", *counts, f"{steps:.2e}"]
    assert counts[list(TASK_KINDS).index("evolve")] == "12"


# -- figures ----------------------------------------------------------------------------------

MINE = {"experiments": {
    "graph": {"kind": "evolve", "shapes": ["worm"], "seeds": 2,
              "figures": {"figure3": "", "figure5": "graph controller", "table1": ""}},
    "fixed": {"kind": "evolve", "shapes": ["worm"], "seeds": 2,
              "options": {"weights_only": True}, "figures": {"figure5": "weights"}},
}}


def test_experiments_declare_their_figures_into_campaign_json():
    campaign = parse(MINE, "mine", "test")
    doc = document(campaign, expand(campaign))
    assert doc["experiments"]["graph"]["figures"] == MINE["experiments"]["graph"]["figures"]
    found = figures.declared({n: e["figures"] for n, e in doc["experiments"].items()})
    assert found["figure5"] == {"graph": "graph controller", "fixed": "weights"}
    assert found["figure3"] == {"graph": "graph"}  # "": the experiment's name
    missing = figures.missing(found)
    # The edge lengths are beyond the paper: a campaign without them lacks nothing.
    assert set(missing) == set(figures.FIGURES) - {"figure3", "figure5", "table1",
                                                   "edge-lengths"}
    assert "no reassemble experiment declares it" in missing["figure7"]
    # The built-ins declare every figure of the paper; lengths the edge lengths of its EAs.
    assert figures.missing(figures.declared({e.name: e.figures for e in
                                             builtin("quick").experiments})) == {}
    lengths = figures.declared({e.name: e.figures for e in builtin("lengths").experiments})
    assert lengths["edge-lengths"] == {e: e for e in ("neutral", "distance-bias",
                                                      "length-delay")}


@pytest.mark.parametrize("change, field", [
    ({"graph": {"figures": {"figure99": ""}}}, "experiments.graph.figures.figure99"),
    ({"graph": {"figures": {"figure7": ""}}}, "experiments.graph.figures.figure7"),
    ({"graph": {"figures": {"figure3": 1}}}, "experiments.graph.figures.figure3"),
    ({"graph": {"figures": ["figure3"]}}, "experiments.graph.figures"),
    ({"fixed": {"figures": {"figure5": "graph controller"}}}, "experiments.fixed.figures"),
    ({"fixed": {"figures": {"table1": ""}}}, "experiments.fixed.figures.table1"),
])
def test_a_figure_that_cannot_be_drawn_is_one_line(change, field):
    data = json.loads(json.dumps(MINE))
    for name, table in change.items():
        data["experiments"][name].update(table)
    with pytest.raises(SomiteError) as error:
        parse(data, "mine", "test")
    assert str(error.value).startswith(f"{field}")
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("figures_there", [{"figure99": ""}, {"figure3": 3}, ["figure3"]])
def test_a_campaign_json_with_bad_figures_is_one_line(tmp_path, capsys, figures_there):
    campaign = parse(MINE, "mine", "test")
    doc = document(campaign, expand(campaign))
    doc["experiments"]["graph"]["figures"] = figures_there
    (tmp_path / "campaign.json").write_text(json.dumps(doc))
    assert main(["campaign", "status", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "campaign.json: experiments.graph.figures" in err
