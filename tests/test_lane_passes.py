"""The lane passes are checked in as ordinary source, generated from their templates: the
file must be what the templates give, so that nobody edits one without the other."""

from __future__ import annotations

from somite.sim import lane_templates


def test_lane_passes_are_generated_from_the_current_templates():
    assert lane_templates.SOURCE.read_text() == lane_templates.render(), (
        "src/somite/sim/lane_passes.py is stale: run python -m somite.sim.lane_templates")


def test_a_template_change_shows():
    before = lane_templates.render()
    lane_templates._PASSES.append("\n\n# an edit")
    try:
        assert lane_templates.render() != before
    finally:
        lane_templates._PASSES.pop()
