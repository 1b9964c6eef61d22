"""Statistics over run directories: read logs, group runs, compare groups (no plotting).

The comparisons are those of the paper's Figures 5, 9 and 11: the distribution of the best
individual's velocity v_x at the last generation, one sample per run, compared pairwise with a
two-sided Mann-Whitney U test (``scipy.stats.mannwhitneyu``; scipy picks the exact null
distribution for small samples without ties). The paper's text reports one one-sided test; the
figures show a p-value per pair of boxes, which is what :func:`pairwise_mann_whitney` gives.

A run directory (written by ``somite evolve``) holds ``config.json`` (the resolved configuration)
and ``log.csv`` (one row per generation, columns :data:`LOG_COLUMNS`).
"""

from __future__ import annotations

import csv
import itertools
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .._io import json_safe, read_json
from ..errors import SomiteError, bad
from ..experiments.logfile import LOG_COLUMNS

NUMERIC_COLUMNS = tuple(c for c in LOG_COLUMNS if c != "best_operator")
OPTIONAL_COLUMNS = ("validation_velocity", "non_finite_episodes")
"""Columns that logs written before they existed lack (read as NaN)."""


@dataclass(frozen=True)
class RunLog:
    """One run directory, read.

    Attributes
    ----------
    path : Path
        The run directory.
    config : dict
        ``config.json`` as parsed JSON.
    log : dict of str to numpy.ndarray
        Every numeric column of ``log.csv`` as a float array (G,), one entry per generation row;
        an empty or unparsable cell is NaN.
    """

    path: Path
    config: dict
    log: dict[str, np.ndarray] = field(repr=False)

    @property
    def n_generations(self) -> int:
        """Rows of the log."""
        return len(self.log["generation"])

    def final(self, column: str = "best_velocity") -> float:
        """The value of ``column`` in the last logged generation."""
        return float(self.log[column][-1])


def load_run(path: str | Path) -> RunLog:
    """Read ``config.json`` and ``log.csv`` of a run directory.

    Raises
    ------
    SomiteError
        When the directory, its config or its log is missing, or the log lacks a column or rows.
    """
    path = Path(path)
    if not path.is_dir():
        raise bad("run", str(path), "no such run directory")
    log_path = path / "log.csv"
    if not log_path.is_file():
        raise bad("run", str(path), "has no log.csv (not a run directory, or nothing logged yet)")
    config_path = path / "config.json"
    if not config_path.is_file():
        raise bad("run", str(path), "has no config.json")
    config = read_json(config_path, "config")
    if not isinstance(config, dict):
        raise bad("config", str(config_path), "expected a JSON object")
    return RunLog(path, config, _read_log(log_path))


def _read_log(path: Path) -> dict[str, np.ndarray]:
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            missing = [c for c in NUMERIC_COLUMNS
                       if c not in (reader.fieldnames or ()) and c not in OPTIONAL_COLUMNS]
            if missing:
                raise bad("log", str(path), f"lacks the columns {missing}")
            # A row cut short by a run still writing has None cells: stop before it.
            rows = [row for row in reader if None not in row.values()]
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise bad("log", str(path), f"cannot read it ({error})") from None
    if not rows:
        raise bad("log", str(path), "has no generation rows yet")
    return {
        c: np.array([number(row.get(c)) for row in rows], dtype=np.float64)
        for c in NUMERIC_COLUMNS
    }


def number(text: str | None) -> float:
    """A log cell as a float: NaN where it is empty or not a number."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def group_label(config: Mapping, keys: Sequence[str]) -> str:
    """``key=value`` for each grouping key, joined by ``, ``; raises if a key is missing."""
    parts = []
    for key in keys:
        if key not in config:
            known = ", ".join(sorted(config))
            raise bad("group_by", key, f"not a key of config.json (keys: {known})")
        parts.append(f"{key}={_show(config[key])}")
    return ", ".join(parts)


def _show(value) -> str:
    return value if isinstance(value, str) else json.dumps(value)


def group_runs(runs: Iterable[RunLog], group_by: str | Sequence[str]) -> dict[str, list[RunLog]]:
    """Runs grouped by the value of one or more ``config.json`` keys (comma-separated string).

    Groups come sorted by their values (numbers numerically, so ``omega=0.1`` precedes
    ``omega=10``); inside a group runs keep their given order.
    """
    keys = _keys(group_by)
    groups: dict[str, list[RunLog]] = {}
    order: dict[str, tuple] = {}
    for run in runs:
        label = group_label(run.config, keys)
        groups.setdefault(label, []).append(run)
        order[label] = tuple(_sort_key(run.config[k]) for k in keys)
    return {label: groups[label] for label in sorted(groups, key=order.__getitem__)}


def _keys(group_by: str | Sequence[str]) -> list[str]:
    keys = [k.strip() for k in group_by.split(",")] if isinstance(group_by, str) else list(group_by)
    if not keys or not all(keys):
        raise bad("group_by", group_by, "name one or more config.json keys, comma-separated")
    return keys


def _sort_key(value) -> tuple:
    # Booleans and numbers before strings, and never compare a number with a string.
    if isinstance(value, (bool, int, float)):
        return (0, float(value), "")
    return (1, 0.0, _show(value))


def final_values(runs: Iterable[RunLog], column: str = "best_velocity") -> np.ndarray:
    """The last generation's ``column`` of each run (NaN dropped), as an array (n_runs,)."""
    values = np.array([run.final(column) for run in runs], dtype=np.float64)
    return values[np.isfinite(values)]


MIN_GROUP_SIZE = 3
"""The fewest values per group for which a Mann-Whitney p-value is shown without a caveat.

The test's exact null distribution has C(n1 + n2, n1) equally likely splits of the pooled
values, so no data can give a p below 1 / C(n1 + n2, n1) one-sided: with n1 = n2 = 2 that is
1/6 (1/3 two-sided), with 2 and 3 it is 1/10, and only from 3 and 3 on (1/20 = 0.05) can the
usual 5 % level be reached at all. Below this size the p-value is kept, with
:func:`small_sample_caveat` beside it."""


def small_sample_caveat(n_a: int, n_b: int) -> str | None:
    """The note beside a Mann-Whitney p-value of samples of ``n_a`` and ``n_b`` values:
    None when both hold at least :data:`MIN_GROUP_SIZE`, or when a sample is empty (no
    p-value at all)."""
    if min(n_a, n_b) >= MIN_GROUP_SIZE or min(n_a, n_b) == 0:
        return None
    return f"n < {MIN_GROUP_SIZE} per group: not meaningful"


def smallest_p(n_a: int, n_b: int) -> float:
    """The smallest two-sided p the exact Mann-Whitney test can give for ``n_a`` and ``n_b``
    values without ties: both extreme splits out of C(n_a + n_b, n_a)."""
    return min(1.0, 2 / math.comb(n_a + n_b, n_a))


class MannWhitney(NamedTuple):
    """A two-sided Mann-Whitney U test: U of the first sample, and the p-value."""

    u: float
    p: float


def mann_whitney(a: Sequence[float], b: Sequence[float]) -> MannWhitney:
    """Two-sided Mann-Whitney U test of samples ``a`` and ``b``.

    U counts the pairs (a_i, b_j) with a_i > b_j, ties counting one half. NaN when a sample
    is empty.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if len(a) == 0 or len(b) == 0:
        return MannWhitney(math.nan, math.nan)
    # Imported here: scipy.stats takes about a second to import, and every ``somite`` command
    # imports this module through the CLI's command discovery.
    from scipy.stats import mannwhitneyu

    result = mannwhitneyu(a, b, alternative="two-sided")
    return MannWhitney(float(result.statistic), float(result.pvalue))


class PairTest(NamedTuple):
    """The Mann-Whitney test of two groups, by label."""

    a: str
    b: str
    n_a: int
    n_b: int
    u: float
    p: float

    @property
    def caveat(self) -> str | None:
        """:func:`small_sample_caveat` of the two groups' sizes."""
        return small_sample_caveat(self.n_a, self.n_b)

    def to_dict(self, name: str = "mann-whitney-u, two-sided") -> dict:
        """The test as report and statistics files write it; ``caveat`` is null when the
        groups are large enough (:data:`MIN_GROUP_SIZE`)."""
        return {"test": name, **self._asdict(), "caveat": self.caveat}


def pairwise_mann_whitney(samples: Mapping[str, Sequence[float]]) -> list[PairTest]:
    """A two-sided Mann-Whitney U test for every pair of groups, in the groups' order."""
    tests = []
    for a, b in itertools.combinations(samples, 2):
        u, p = mann_whitney(samples[a], samples[b])
        tests.append(PairTest(a, b, len(samples[a]), len(samples[b]), u, p))
    return tests


def describe(values: Sequence[float]) -> dict:
    """n, median, mean, standard deviation (ddof 0), min and max; NaN for an empty sample."""
    x = np.asarray(values, dtype=np.float64)
    if len(x) == 0:
        return {"n": 0, **{k: math.nan for k in ("median", "mean", "std", "min", "max")}}
    return {
        "n": int(len(x)),
        "median": float(np.median(x)),
        "mean": float(np.mean(x)),
        "std": float(np.std(x)),
        "min": float(np.min(x)),
        "max": float(np.max(x)),
    }


def run_statistics(
    groups: Mapping[str, Sequence[RunLog]], column: str = "best_velocity"
) -> dict:
    """What ``somite plot`` writes as JSON: per group the final ``column`` of every run and its
    summary, the pairwise two-sided Mann-Whitney tests (each with its ``caveat``, null unless
    a group is smaller than :data:`MIN_GROUP_SIZE`), the runs whose v_x was measured over
    the whole episode (:func:`measures_whole_episode`) and, as ``left_out``, the runs whose
    final ``column`` is NaN or infinite, which no group's numbers count (:func:`final_values`).

    NaN (an empty group or a failed test) is written as null by :func:`to_json`.
    """
    samples = {label: final_values(runs, column) for label, runs in groups.items()}
    sizes = {label: final_values(runs, "best_size") for label, runs in groups.items()}
    return {
        "column": column,
        "groups": {
            label: {
                "runs": [str(run.path) for run in groups[label]],
                "final": [float(v) for v in samples[label]],
                **describe(samples[label]),
                "final_best_size": describe(sizes[label]),
            }
            for label in groups
        },
        "tests": [test.to_dict() for test in pairwise_mann_whitney(samples)],
        # v_x over [0, duration] is not v_x over [transient, duration]: named, not hidden.
        "whole_episode_runs": [str(run.path) for runs in groups.values() for run in runs
                               if measures_whole_episode(run.config)],
        # A run whose last best is NaN is in no box and no test: named, not dropped unseen.
        "left_out": [str(run.path) for runs in groups.values() for run in runs
                     if not math.isfinite(run.final(column))],
    }


def measures_whole_episode(config: Mapping) -> bool:
    """Whether a run's ``config.json`` had v_x measured over the whole episode (a duration
    no longer than the transient, :attr:`~somite.sim.config.SimConfig.measures_whole_episode`);
    False when it lacks either setting."""
    from ..sim.config import SimConfig

    duration, transient = config.get("duration"), config.get("transient")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool)
               for v in (duration, transient)):
        return False
    try:
        config = SimConfig(duration=float(duration), transient=float(transient))
    except SomiteError:  # settings no episode could have run with: nothing to say about them
        return False
    return config.measures_whole_episode


def to_json(data) -> str:
    """Strict JSON (NaN and infinities become null)."""
    return json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n"


