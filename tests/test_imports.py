"""Which parts of somite may import which (the package's intended layering).

Read statically from the source, so an import inside a function counts like one at the top:

- the foundation (``errors``, ``limits``, ``budget``, ``_io``, ``_jit``, ``_threads``, ``_math``,
  ``_arrays``, ``formats``, ``types``, ``checks``) imports no other part;
- ``sim`` (physics and the body description) and ``brain`` (the controller) are independent,
  except that a genome is written for a body: ``brain`` may import ``sim.body``, which itself
  imports nothing of the simulator but its table of sensor kinds (``sim.sensor_kinds``);
- ``tasks`` is where sim and brain meet; ``evolution`` and ``modules`` sit above it and do not
  import each other (a partition describes a body, so both take it from ``sim.partition``);
  ``experiments``, ``analysis`` and ``viz`` above those; ``campaigns`` (experiments on Dask)
  above ``experiments`` (its task kinds read their runs with ``analysis``); ``commands`` and
  ``cli`` on top;
- plotting and imaging libraries only in ``viz``; the progress bar only in the command line.
- ``report`` (a campaign's report) reads every part below the command line, which imports it.
- ``envs`` (the Gymnasium environments) sits beside ``viz``, whose frames it renders; Gymnasium
  only there.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "src" / "somite"

FOUNDATION = {"errors", "limits", "budget", "_io", "_jit", "_threads", "_math", "types", "formats",
              "checks", "_cycles", "_arrays", "_visible"}
BELOW_TOP = {"sim", "brain", "tasks", "evolution", "modules", "experiments", "analysis", "viz",
             "bench", "campaigns", "envs"}
ALLOWED = {
    "sim": set(),
    "brain": {"sim.body"},
    "tasks": {"sim", "brain"},
    "evolution": {"sim", "brain", "tasks"},
    "modules": {"sim", "brain", "tasks"},
    "experiments": {"sim", "brain", "tasks", "evolution", "modules"},
    "analysis": {"sim", "brain", "tasks", "evolution", "modules", "experiments"},
    "viz": {"sim", "brain", "tasks", "evolution", "modules", "experiments", "analysis"},
    "report": BELOW_TOP | {"__init__"},
    "bench": {"sim", "brain", "tasks"},
    "envs": {"sim", "brain", "tasks", "viz"},
    "campaigns": {"sim", "brain", "tasks", "evolution", "modules", "experiments", "analysis"},
    "__init__": BELOW_TOP,
    "commands": BELOW_TOP | {"commands", "__init__", "report"},
    "cli": {"commands", "__init__"},  # the package's version
}
"""Part of somite -> the other parts it may import (besides the foundation)."""

BODY_DESCRIPTION = {"sim.body", "sim.sensor_kinds"}
"""Modules of ``sim`` that ``brain`` may import: they may import only the foundation."""

EXTERNAL = {
    "matplotlib": {"viz"},
    "PIL": {"viz"},
    "imageio": {"viz"},
    "rich": {"commands", "cli"},
    "distributed": {"campaigns"},
    "dask": {"campaigns"},
    "gymnasium": {"envs"},
}
"""Third-party package -> the parts of somite that may import it."""


def modules() -> list[Path]:
    return sorted(SOURCE.rglob("*.py"))


def dotted(path: Path) -> str:
    """``somite/sim/body.py`` -> ``sim.body``; ``somite/sim/__init__.py`` -> ``sim``."""
    parts = list(path.relative_to(SOURCE).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts.pop()
    return ".".join(parts)


def imported(path: Path) -> set[str]:
    """Every module ``path`` imports: somite's as ``sim.body``, others as ``ext:numpy``."""
    package = dotted(path).split(".")
    if path.name != "__init__.py" or package == ["__init__"]:
        package = package[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {_absolute(alias.name) for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            found.add(_absolute(node.module))
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - (node.level - 1)]
            if node.module:
                found.add(".".join([*base, node.module]))
            else:  # from . import kernels
                found |= {".".join([*base, alias.name]) for alias in node.names}
    return {name for name in found if name != "ext:__future__"}


def _absolute(name: str) -> str:
    if name == "somite":
        return "__init__"
    if name.startswith("somite."):
        return name[len("somite."):]
    return "ext:" + name.split(".")[0]


def violations(module: str, names: set[str]) -> list[str]:
    """The imports of ``module`` (``sim.body``) that the rules above forbid."""
    owner = module.split(".")[0]
    wrong = []
    for name in sorted(names):
        target = name.split(".")[0]
        if name.startswith("ext:"):
            ok = owner in EXTERNAL.get(name[4:], {owner})
        elif owner in FOUNDATION:
            ok = target in FOUNDATION
        elif module in BODY_DESCRIPTION:
            ok = target in FOUNDATION or name in BODY_DESCRIPTION
        else:
            ok = target in FOUNDATION | {owner} | ALLOWED[owner] or name in ALLOWED[owner]
        if not ok:
            wrong.append(name)
    return wrong


def test_the_rules_cover_every_part_of_somite():
    parts = {dotted(path).split(".")[0] for path in modules()}
    assert parts <= set(ALLOWED) | FOUNDATION, parts - set(ALLOWED) - FOUNDATION


@pytest.mark.parametrize("path", modules(), ids=dotted)
def test_imports_follow_the_layers(path):
    module = dotted(path)
    assert violations(module, imported(path)) == [], module


@pytest.mark.parametrize(
    "module, name",
    [("sim.system", "brain.genome"), ("brain.genome", "sim.physics"), ("sim.body", "sim.config"),
     ("evolution.operators", "modules.module"), ("modules.module", "evolution.ea"),
     ("tasks.episode", "viz.frame"), ("evolution.ea", "ext:matplotlib"), ("_io", "sim.body"),
     ("experiments.runner", "ext:rich"), ("viz.video", "commands.common")],
)
def test_the_rules_catch_a_forbidden_import(module, name):
    assert violations(module, {name}) == [name]


def test_the_reader_resolves_relative_imports():
    assert {"sim.body", "brain.kinds", "errors", "_io", "ext:numpy"} <= imported(
        SOURCE / "brain" / "genome.py"
    )
    assert "commands" in imported(SOURCE / "cli.py")
