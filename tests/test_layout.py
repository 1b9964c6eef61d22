"""The functions that allocate a robot's arrays and take its views of a batch's are generated
from the tables that describe those arrays and checked in as ordinary source: each file must be
what its table gives, so that nobody edits one without the other."""

from __future__ import annotations

import numpy as np

from somite.sim import layout
from somite.sim.state import BODY_PARTS
from somite.tasks import layout as work_layout
from somite.tasks.work import WORK_PARTS

STALE = "is stale: run python -m somite.tasks.layout"


def test_the_generated_views_are_those_of_the_current_tables():
    assert layout.BODY_SOURCE.read_text() == layout.render_body(), f"{layout.BODY_SOURCE} {STALE}"
    assert work_layout.SOURCE.read_text() == work_layout.render(), f"{work_layout.SOURCE} {STALE}"


def test_a_table_change_shows_in_the_generated_source():
    body, work = layout.render_body(), work_layout.render()
    BODY_PARTS["joints"]["extra"] = (("S", 2), np.float64)
    WORK_PARTS["brain"]["extra"] = (("N",), np.float64)
    try:
        assert "np.empty((s, 2), dtype=np.float64),  # extra" in layout.render_body()
        assert "bodies.extra[b, :s]," in layout.render_body()
        assert "work.brain.extra[b, :n]," in work_layout.render()
    finally:
        del BODY_PARTS["joints"]["extra"], WORK_PARTS["brain"]["extra"]
    assert (layout.render_body(), work_layout.render()) == (body, work)
