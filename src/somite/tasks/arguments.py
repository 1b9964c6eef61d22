"""Arguments of somite's own types, checked as :mod:`somite.checks` checks numbers: a
:class:`~somite.sim.config.SimConfig`, a terrain (or its name), a body, a genome, a robot (a
genome or a controller), a backend's name. Each refuses in one line naming the argument."""

from __future__ import annotations

from ..brain.control import CONTROLLER_TYPES
from ..brain.genome import Genome
from ..checks import instance, items, named, text
from ..errors import bad
from ..sim.body import Body
from ..sim.config import SimConfig
from ..sim.terrain import Terrain, parse_terrain
from .backends import check_backend


def sim_config(field: str, value):
    """``value``, a :class:`~somite.sim.config.SimConfig`, or one by default for None."""
    if value is None:
        return SimConfig()
    return instance(field, value, SimConfig, "a somite SimConfig (somite.preset(...))")


def terrain(field: str, value):
    """A :class:`~somite.sim.terrain.Terrain` or a terrain name, as a Terrain."""
    if isinstance(value, Terrain):
        return value
    return named(field, parse_terrain, text(field, value))


def body(field: str, value):
    return instance(field, value, Body, "a somite Body (somite.Body.build(...))")


def genome(field: str, value):
    return instance(field, value, Genome, "a somite Genome")


def genomes(field: str, value, most: int) -> list:
    """A list of at most ``most`` :class:`~somite.brain.genome.Genome`."""
    listed = items(field, value, most)
    for i, item in enumerate(listed):
        genome(f"{field}[{i}]", item)
    return listed


def robot(field: str, value):
    """``value``, a :class:`~somite.brain.genome.Genome` or a controller of a type in
    :data:`~somite.brain.control.CONTROLLER_TYPES` (``Zero()``, ``Sine(...)``, ``Table(...)``,
    a compiled genome)."""
    return instance(field, value, (Genome, *(entry.spec for entry in CONTROLLER_TYPES)),
                    "a Genome or a controller (somite.Zero(), somite.Sine(...), somite.Table(...))")


def backend(field: str, value) -> str:
    return check_backend(text(field, value))


def terrains(field: str, value, n: int, most: int):
    """One terrain for ``n`` robots (a name or a Terrain, for all) or one per robot, of at
    most ``most``; as a list of ``n`` Terrains. One name is parsed once."""
    if isinstance(value, (str, Terrain)):
        return [terrain(field, value)] * n
    listed = items(field, value, most, least=1,
                   expected="a terrain name, a Terrain or a list of them")
    if len(listed) != n:
        raise bad(field, f"{len(listed)} terrains", f"need one, or one per robot ({n})")
    parsed: dict[str, Terrain] = {}
    worlds = []
    for i, item in enumerate(listed):
        if isinstance(item, str) and item in parsed:
            worlds.append(parsed[item])
            continue
        world = terrain(f"{field}[{i}]", item)
        if isinstance(item, str):
            parsed[item] = world
        worlds.append(world)
    return worlds


__all__ = ["backend", "body", "genome", "genomes", "robot", "sim_config", "terrain", "terrains"]
