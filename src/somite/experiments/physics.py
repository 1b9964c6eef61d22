"""Which physics a run ran under: its ``physics.json``, written when it starts.

``{"format": "somite-run-physics", "version": 1, "started": PHYSICS, "forced": [...]}``:
``started`` is :data:`somite.sim.version.PHYSICS` when the run began (null for a run of a
somite before physics versions, given one by a forced resume); ``forced`` lists every resume
under another physics that the user forced (``--force-physics``), each with the checkpoint's
generation it went on from, the physics before and the physics after. The run's physics is
the last one there. A resume under any other physics is refused in one line naming both, before
any file is touched: a run whose generations come from two kernels is not the run its log
claims to be.
"""

from __future__ import annotations

import json
from pathlib import Path

from .._io import read_json, write_atomic
from ..errors import bad
from ..formats import RUN_PHYSICS
from ..sim.version import PHYSICS

PHYSICS_FILE = "physics.json"


def started() -> str:
    """``physics.json`` of a run that starts now."""
    return _text({**RUN_PHYSICS.header(), "started": PHYSICS, "forced": []})


def _text(record: dict) -> str:
    """One line: a line moved or repeated is then a damaged file, never the same record."""
    return json.dumps(record, separators=(",", ":")) + "\n"


def read(folder: Path) -> dict | None:
    """The run's physics record (None: it has none), or a one-line error."""
    path = folder / PHYSICS_FILE
    if not path.is_file():
        return None
    data = read_json(path, "physics")
    RUN_PHYSICS.check(data, "physics", str(path))
    forced = data.get("forced")
    if not (isinstance(data.get("started"), (str, type(None))) and isinstance(forced, list)
            and all(isinstance(f, dict) and isinstance(f.get("physics"), str) for f in forced)):
        raise bad("physics", str(path), "damaged physics.json (started and forced expected)")
    return data


def ran_under(record: dict | None) -> str | None:
    """The physics a run last ran under (None: not recorded)."""
    if record is None:
        return None
    return record["forced"][-1]["physics"] if record["forced"] else record["started"]


def check_resume(folder: Path, force: bool, generation: int, flag: str = "--force-physics"
                 ) -> str | None:
    """Refuse to resume the run in ``folder`` from ``generation`` under a physics other than
    the one it ran under, unless ``force``; returns the text of ``physics.json`` to write
    before resuming (a forced resume, recorded), or None (nothing to write)."""
    record = read(folder)
    before = ran_under(record)
    if before == PHYSICS:
        return None
    shown = f"physics {before!r}" if before else ("a physics it did not record (a somite "
                                                  "before physics versions)")
    if not force:
        raise bad("physics", before, f"run {folder} ran under {shown}, this somite's "
                  f"physics is {PHYSICS!r}: resuming would mix two kernels in one run "
                  f"({flag} resumes it anyway, and its physics.json records that)")
    record = record or {**RUN_PHYSICS.header(), "started": None, "forced": []}
    record["forced"].append({"generation": generation, "from": before, "physics": PHYSICS})
    return _text(record)


def force_record(folder: Path, text: str) -> None:
    write_atomic(folder / PHYSICS_FILE, text)


__all__ = ["PHYSICS", "PHYSICS_FILE", "check_resume", "force_record", "ran_under", "read",
           "started"]
