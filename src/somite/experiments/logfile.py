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
    "non_finite_episodes",
    "validation_velocity",
)
"""One row per generation, in this order. ``nan_count``: offspring whose fitness is NaN (an
episode's physics went non-finite); ``non_finite_episodes``: episodes of the generation with a
NaN or infinite controller output or physics state (empty in rows of a caller that did not
count them). ``validation_velocity`` is the best's mean v_x on the fixed validation terrains,
in the rows where it was measured (empty elsewhere)."""


def format_cell(value) -> str:
    """A log cell: floats exactly (repr), None as an empty cell."""
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else str(value)


def format_row(row: dict) -> str:
    """A log row as one CSV line (no newline), the columns in :data:`LOG_COLUMNS` order."""
    return ",".join(format_cell(row[c]) for c in LOG_COLUMNS)


def last_validation(rows) -> float | None:
    """The validation v_x of the last of ``rows`` (a log's rows, as csv.DictReader gives them)
    that measured one (a run validates every few generations); None if none did. A NaN is
    returned as such: it is the validation of the latest best, and an earlier number would be
    another genome's."""
    for row in reversed(rows):
        cell = row.get("validation_velocity")
        if cell:
            try:
                return float(cell)
            except ValueError:
                continue
    return None

