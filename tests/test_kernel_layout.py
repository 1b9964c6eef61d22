"""The kernel's layout rules that a reader relies on, read from the source.

A compiled function takes at most 8 parameters, unless it is a *function of values*: one
joint's or one body's arithmetic on numbers (``physics.spring_terms``, ``pushed``, ...), whose
parameters are never indexed or read into. A function that takes arrays or named tuples groups
them (a solver, a batch, a robot's state) instead of passing them one by one."""

from __future__ import annotations

import ast
from pathlib import Path

import somite

SOURCE = Path(somite.__file__).parent
MOST_PARAMETERS = 8


def compiled_functions():
    for path in sorted(SOURCE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.FunctionDef) and any(
                    "jit" in ast.unparse(d) or "uncounted" in ast.unparse(d)
                    for d in node.decorator_list):
                yield path.relative_to(SOURCE), node


def reads_into_a_parameter(function: ast.FunctionDef) -> bool:
    names = {a.arg for a in function.args.args}
    return any(isinstance(node, ast.Subscript | ast.Attribute)
               and isinstance(node.value, ast.Name) and node.value.id in names
               for node in ast.walk(function))


def test_compiled_functions_that_take_arrays_take_at_most_eight_parameters():
    found = list(compiled_functions())
    assert len(found) > 100  # the scan sees the kernel
    wide = [f"{path}:{f.lineno} {f.name} ({len(f.args.args)})" for path, f in found
            if len(f.args.args) > MOST_PARAMETERS and reads_into_a_parameter(f)]
    assert wide == []


def test_the_rule_tells_values_from_arrays():
    values, arrays = (ast.parse(text).body[0] for text in (
        "def f(a, b):\n    return a * b",
        "def f(a, b):\n    return a[0] + b.x"))
    assert not reads_into_a_parameter(values)
    assert reads_into_a_parameter(arrays)
