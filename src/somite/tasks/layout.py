"""The source of :mod:`somite.tasks.work_views` (and of :mod:`somite.sim.state_views`), written
from the tables :data:`somite.tasks.work.WORK_PARTS` and
:data:`somite.sim.state.BODY_PARTS` as :mod:`somite.sim.layout` says.

After editing a table: ``python -m somite.tasks.layout``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..sim import layout
from ..sim.state import BODY_COUNTS
from .work import PART_TYPES, WORK_COUNTS, WORK_PARTS

SOURCE = Path(__file__).with_name("work_views.py")

_BODY = "physics"
"""The part of :data:`WORK_PARTS` that is the physics' :class:`~somite.sim.state.BodyState`."""


def _parts(make_body: str, make_part, make_tally: str) -> str:
    lines = []
    for part, fields in WORK_PARTS.items():
        if part == _BODY:
            lines.append(f"        {make_body},\n")
        elif part in PART_TYPES:
            lines.append(f"        {PART_TYPES[part].__name__}(\n{make_part(part, fields)}"
                         "        ),\n")
        else:
            lines.append(f"        {make_tally(part, fields)},\n")
    return "".join(lines)


def render() -> str:
    """The text of ``work_views.py``."""
    args, body = layout.counts(WORK_COUNTS), layout.counts(BODY_COUNTS)
    names = ", ".join(sorted(["Work", *(t.__name__ for p, t in PART_TYPES.items() if p != _BODY)]))
    allocate = _parts(
        f"new_body(({body}))", lambda part, fields: layout.allocations(fields, " " * 12),
        lambda part, fields: layout.allocations(fields, "").split(",  #")[0])
    view = _parts(
        f"body_row(work.{_BODY}, b, ({body}))",
        lambda part, fields: layout.views(fields, f"work.{part}", " " * 12),
        lambda part, fields: layout.views(fields, "work", "").strip().rstrip(","))
    generated = layout.GENERATED.format(table=":data:`somite.tasks.work.WORK_PARTS`")
    return f'''"""Robots' :class:`~somite.tasks.work.Work`: allocated, and as views of a batch's.

{generated}
"""

# ruff: noqa: E501

import numpy as np

from .._jit import njit
from ..sim.state_views import body_row, new_body
from .work import {names}


@njit
def new_robot_work(counts):
    """A robot's own :class:`Work` for its ``counts`` ({", ".join(WORK_COUNTS)}),
    uninitialised."""
    {args} = counts
    return Work(
{allocate}    )


@njit(inline="always")
def work_views(work, b, counts):
    """Robot ``b``'s :class:`Work` as views of a batch's ``work``, trimmed to its ``counts``
    ({", ".join(WORK_COUNTS)})."""
    {args} = counts
    return Work(
{view}    )
'''


def write_all() -> None:
    """Write both generated files."""
    layout.write(layout.BODY_SOURCE, layout.render_body())
    layout.write(SOURCE, render())


if __name__ == "__main__":
    write_all()
    print(f"wrote {layout.BODY_SOURCE} and {SOURCE}", file=sys.stderr)
