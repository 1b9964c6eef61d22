"""Names and paths of a campaign directory that every part of it shares.

``campaign.json`` at the top, one folder per task (its path is its id), ``done.json`` written
last in a finished task's folder; a path inside the folder is relative, normalised, and not
one of the folder's own files. An error about ``campaign.json`` names its field with
:func:`at` (``campaign.json: tasks[3].path``).
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath

from ..errors import bad
from ..experiments.lock import LOCK_NAME

CAMPAIGN = "campaign.json"
DONE = "done.json"
MAX_FOLDER_NAME = 255
"""Bytes of one folder name (most file systems' limit)."""


def read_done(folder: Path) -> dict | None:
    """The ``done.json`` record of the task in ``folder``; None when there is none
    or it is not whole: not JSON (cut short by a kill or a full disk), not a JSON object (the
    probe's ``[]``). Such a task is not finished: it runs again (every kind
    resumes or redoes its work), and its record is written anew."""
    from .._io import parse_json, read_text

    path = folder / DONE
    try:
        if not path.is_file():
            return None
        data = parse_json(read_text(path, "done"), "done", str(path))
    except (OSError, ValueError):  # SomiteError is a ValueError
        return None
    # Not compared with the task's id: a campaign's experiments may be renamed (their
    # folders and ids with them) after their tasks finished.
    return data if isinstance(data, dict) else None


def at(where: str) -> str:
    """The name of a field of ``campaign.json`` in an error."""
    return f"{CAMPAIGN}: {where}"


def path_problem(text: str) -> str | None:
    """Why ``text`` is not a normalised relative path inside a campaign folder, or None."""
    if any(ord(c) < 32 or c == "\\" for c in text):
        return "no backslashes or control characters"
    if PurePosixPath(text).is_absolute():
        return "not absolute"
    parts = text.split("/")
    if ".." in parts:
        return "no '..'"
    if any(part in ("", ".") for part in parts):
        return "normalised: no empty or '.' parts"
    if any(len(part.encode()) > MAX_FOLDER_NAME for part in parts):
        return f"folder names of at most {MAX_FOLDER_NAME} bytes"
    if parts[0] in (CAMPAIGN, LOCK_NAME):
        return f"not the campaign folder's own {parts[0]}"
    return None


def inside(where: str, text: str) -> None:
    """``text`` is a relative path inside the campaign folder, or a one-line error."""
    problem = path_problem(text)
    if problem is not None:
        raise bad(at(where), text,
                  f"must be a relative path inside the campaign folder ({problem})")
