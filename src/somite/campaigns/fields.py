"""Checks of a campaign file's fields, shared by the campaign (:mod:`.spec`) and the
experiment kinds (:mod:`.kinds`): every error one line naming the field and its value."""

from __future__ import annotations

from pathlib import Path

from ..errors import bad
from .layout import CAMPAIGN

_NAME_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789-_.")
MAX_NAME = 64
"""Characters of an experiment's or a variant's name (a folder name, and part of task ids)."""
_RESERVED = (CAMPAIGN,)
"""Names a campaign directory holds already (its experiments are its top-level folders)."""
CAMPAIGN_DECIDES = {
    "shape": "the experiment's shapes decide each run's shape",
    "seed": "the experiment's seeds decide each run's seed",
    "start": "an evolve run starts from scratch, a re-optimisation from its reassembly",
}
"""Run options a campaign decides itself (refused where they would be ignored)."""


def check_name(field: str, name: str) -> None:
    """An experiment's or a variant's name: a folder name, safe on every file system."""
    if not name or not set(name) <= _NAME_CHARS or name[0] in "-._":
        raise bad(field, name, "names use a-z, 0-9, '-', '_' and '.', and start with a letter "
                  "or digit")
    if len(name) > MAX_NAME:
        raise bad(field, name, f"names are at most {MAX_NAME} characters")
    if name in _RESERVED:
        raise bad(field, name, "is the name of the campaign directory's own file")


def typed(table: dict, key: str, kind: type, default, where: str = ""):
    """``table[key]`` checked to be a ``kind`` (ints are not bools), or ``default`` if absent
    (None: required)."""
    if key not in table:
        if default is None:
            raise bad(where + key, None, "required")
        return default
    value = table[key]
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise bad(where + key, value, f"must be of type {kind.__name__}")
    return value


def run_table(options: dict, where: str, decided: dict[str, str], base: Path) -> dict:
    """Run options of the campaign file (``where`` names them): a key the campaign decides is
    refused (it would be ignored), a partition file of ``modules`` is made absolute."""
    for key, why in decided.items():
        if key in options:
            raise bad(where + key, options[key], f"ignored in a campaign: {why}")
    options = dict(options)
    if isinstance(options.get("modules"), str):
        options["modules"] = file_path(options["modules"], base)
    return options


def file_path(spec: str, base: Path) -> str:
    """A partition given as a file (``*.json``) as an absolute path, relative ones read from
    ``base``; presets and grids of labels as they are."""
    if not spec.strip().endswith(".json"):
        return spec
    return str((base / spec.strip()).resolve())


def earlier(table: dict, key: str, where: str, before: dict, kind: str) -> tuple[str, ...]:
    """The experiment(s) ``table[key]`` names: defined before this one (``before``: name ->
    experiment), of ``kind``."""
    value = table.get(key)
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise bad(where + key, value, f"name a {kind} experiment (or a list of them)")
    for name in names:
        if name not in before:
            raise bad(where + key, name, "no such experiment before this one")
        if before[name].kind != kind:
            raise bad(where + key, name, f"is a {before[name].kind} experiment, not {kind}")
    if len(set(names)) != len(names):
        raise bad(where + key, value, "an experiment is named twice")
    return tuple(names)
