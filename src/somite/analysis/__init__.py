"""Statistics over run directories (significance tests, summaries); no plotting here."""

from .stats import (
    LOG_COLUMNS,
    MIN_GROUP_SIZE,
    MannWhitney,
    PairTest,
    RunLog,
    describe,
    final_values,
    group_runs,
    load_run,
    mann_whitney,
    pairwise_mann_whitney,
    run_statistics,
    small_sample_caveat,
)

__all__ = [
    "LOG_COLUMNS",
    "MIN_GROUP_SIZE",
    "MannWhitney",
    "PairTest",
    "RunLog",
    "describe",
    "final_values",
    "group_runs",
    "load_run",
    "mann_whitney",
    "pairwise_mann_whitney",
    "run_statistics",
    "small_sample_caveat",
]
