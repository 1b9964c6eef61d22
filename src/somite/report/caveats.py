"""What the report says before any number: when the campaign's numbers mean little.

Four caveats, each in report.json's ``caveats`` with the text index.md shows at its top (and
``somite report`` prints as a warning): a budget too small for evolution to have done anything
(:data:`MIN_GENERATIONS`), episodes no longer than their transient (v_x over the whole
episode), p-values of groups too small for them (:data:`~somite.analysis.stats.
MIN_GROUP_SIZE`, marked beside each p-value as well) and an interim report, one that draws
runs still under way.
"""

from __future__ import annotations

from ..analysis.stats import MIN_GROUP_SIZE, RunLog, describe, measures_whole_episode
from .campaign import CampaignFolder

MIN_GENERATIONS = 100
"""Evolve runs of fewer generations than this get the banner that their numbers mean nothing.

The paper's runs have 3000 generations and its best v_x still climbs after several hundred
(Figure 3); the built-in ``quick`` campaign has 150, ``smoke`` 2. After a few dozen
generations a best is its random initial genome plus a handful of mutations, so its v_x, size
and every comparison between experiments measure the initial draw and the training terrains'
luck, not what evolution (or omega, or the ablation) did. 100 sits between the two budgets
that differ in kind: below ``quick``, far above ``smoke``."""


def budget(campaign: CampaignFolder, runs: dict[str, RunLog]) -> dict:
    """Generations and population of the finished evolve runs (``runs``: task id -> run),
    and the caveat when every one of them falls short of :data:`MIN_GENERATIONS`."""
    evolved = [runs[t.id] for t in campaign.of_kind("evolve") if t.id in runs]
    generations = [_generations(run) for run in evolved]
    population = [run.config["population"] for run in evolved
                  if isinstance(run.config.get("population"), int)]
    out = {"runs": len(evolved), "generations": describe(generations),
           "population": describe(population), "min_generations": MIN_GENERATIONS,
           "caveat": None}
    if generations and max(generations) < MIN_GENERATIONS:
        most = _count(max(generations), "generation")
        of = f" of a population of {max(population)}" if population else ""
        out["caveat"] = (
            f"smoke-sized budget, these numbers mean nothing: the evolve runs have at most "
            f"{most}{of}, fewer than {MIN_GENERATIONS} (the paper: 3000 generations of 96), so "
            "every best is still close to its random initial genome and every comparison "
            "below measures that draw, not evolution")
    return out


def _generations(run: RunLog) -> int:
    """Generations after the initial population: config.json's, else the log's rows."""
    planned = run.config.get("generations")
    return planned if isinstance(planned, int) else run.n_generations - 1


def _count(n: int, what: str) -> str:
    return f"{n} {what}" if n == 1 else f"{n} {what}s"


def whole_episode(runs: dict[str, RunLog]) -> dict:
    """The runs (evolve and re-optimisation) whose v_x is over the whole episode, start-up
    included, since their duration is no longer than their transient; and the caveat."""
    found = [task for task, run in runs.items() if measures_whole_episode(run.config)]
    out = {"tasks": found, "caveat": None}
    if found:
        first = runs[found[0]].config
        out["caveat"] = (
            f"{len(found)} of {len(runs)} runs had a duration no longer than their transient "
            f"(e.g. {found[0]}: {first['duration']:g} s, transient {first['transient']:g} s): "
            "their v_x is measured over the whole episode [0, duration], start-up included, "
            "not over [transient, duration] as in the paper")
    return out


def small_groups(report: dict) -> dict:
    """How many of the report's Mann-Whitney tests compare a group of fewer than
    :data:`~somite.analysis.stats.MIN_GROUP_SIZE` values (each marked beside its p-value)."""
    tests = list(_tests(report))
    flagged = sum(1 for t in tests if t.get("caveat"))
    out = {"tests": len(tests), "flagged": flagged, "min_group_size": MIN_GROUP_SIZE,
           "caveat": None}
    if flagged:
        out["caveat"] = (f"{flagged} of {len(tests)} p-values compare a group of fewer than "
                         f"{MIN_GROUP_SIZE} runs and mean nothing (each is marked "
                         f"\"n < {MIN_GROUP_SIZE} per group: not meaningful\")")
    return out


def _tests(data):
    """Every Mann-Whitney test record anywhere in ``data``."""
    if isinstance(data, dict):
        if str(data.get("test", "")).startswith("mann-whitney"):
            yield data
            return
        for value in data.values():
            yield from _tests(value)
    elif isinstance(data, list):
        for value in data:
            yield from _tests(value)


def under_way(report: dict) -> dict:
    """The runs still under way that the curves show (``somite report --under-way``), and
    the caveat that the report is an interim one."""
    found = (report.get("status") or {}).get("under_way") or {}
    out = {"tasks": list(found), "caveat": None}
    if found:
        runs = ", ".join(f"{task} at generation {r['generation']}"
                         + (f" of {r['generations']}" if r.get("generations") else "")
                         for task, r in found.items())
        out["caveat"] = (
            f"interim report: {_count(len(found), 'run')} still under way ({runs}), drawn to "
            "their last logged generation in the curves of Figures 3 and 10 where their "
            "experiment feeds them and in the cuts during evolution, in the time-lapses and in "
            "the tables at the same budget (Figure 5's, the cuts'); every other table, test "
            "and final figure holds the finished runs only")
    return out


def caveats(campaign: CampaignFolder, runs: dict[str, RunLog], report: dict) -> dict:
    """report.json's ``caveats``: each of the four, and ``banner``, the texts of those that
    apply, in the order index.md shows them."""
    out = {"budget": budget(campaign, runs), "whole_episode": whole_episode(runs),
           "small_groups": small_groups(report), "under_way": under_way(report)}
    out["banner"] = [c["caveat"] for c in out.values() if c["caveat"]]
    return out


__all__ = ["MIN_GENERATIONS", "budget", "caveats", "small_groups", "under_way",
           "whole_episode"]
