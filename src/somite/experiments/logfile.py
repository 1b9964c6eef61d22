"""The columns of a run's ``log.csv``: written by the runner, read by the analysis.

A module of its own so that reading logs does not import the EA.
"""

LOG_COLUMNS = (
    "generation",
    "evaluations",
    "elapsed_seconds",
    "best_velocity",
    "median_velocity",
    "worst_velocity",
    "best_nodes",
    "best_edges",
    "best_size",
    "median_size",
    "best_operator",
    "nan_count",
)
"""One row per generation, in this order."""
