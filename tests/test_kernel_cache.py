"""The compiled-kernel cache is keyed on the kernels' sources (``somite._jit``): an edit in any
file a kernel is built from is seen on the next call, without clearing anything."""

from __future__ import annotations

import ast
import fcntl
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from somite import _jit

SOURCE = Path(_jit.__file__).resolve().parent
KERNELS_FIRST = False
"""conftest: the subprocesses here run a copy of the package, with caches of its own."""

# A kernel of brain/kernels.py on a one-node graph: a sensor node reads tanh(0.5), tanh being a
# helper of another file (_math.py).
GRAPH_STEP = """
import numpy as np
from somite import _jit
from somite.brain.kernels import Graph, graph_step
from somite.brain.kinds import SENSOR
none = np.zeros(0, np.int32)
graph = Graph(1, np.array([SENSOR], np.int32), np.zeros(1, np.int32), 0, none, none,
              np.zeros(0), np.zeros(0))
h = np.zeros(1)
graph_step(graph, np.zeros(1), h, np.array([0.5]), np.zeros(1), False)
print(repr(float(h[0])), _jit.KERNEL_CACHE)
"""

TANH = "    return math.copysign((1.0 - e) / (1.0 + e), x)\n"


def _package_copy(tmp_path: Path) -> Path:
    root = tmp_path / "copy"
    shutil.copytree(SOURCE, root / "somite", ignore=shutil.ignore_patterns("__pycache__"))
    return root


def _run(root: Path, script: str, **env) -> list[str]:
    environ = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_DIR", "SOMITE_KERNEL_CACHE")}
    environ.update(PYTHONPATH=str(root), **env)
    done = subprocess.run([sys.executable, "-c", script], cwd=root, env=environ,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_an_edit_of_a_helper_in_another_file_is_seen_on_the_next_call(tmp_path):
    root = _package_copy(tmp_path)
    helper = root / "somite" / "_math.py"
    original = helper.read_text()
    assert TANH in original

    before, first_folder = _run(root, GRAPH_STEP)
    assert before == repr(0.46211715726000974)  # tanh(0.5)
    # The second run loads what the first compiled: the same folder.
    assert _run(root, GRAPH_STEP) == [before, first_folder]

    helper.write_text(original.replace(TANH, "    return 0.5 * math.copysign((1.0 - e) / "
                                             "(1.0 + e), x)\n"))
    after, edited_folder = _run(root, GRAPH_STEP)
    assert float(after) == 0.5 * float(before)
    assert edited_folder != first_folder

    # Back to the original source: its folder is kept (KEPT), and its kernel is right again.
    helper.write_text(original)
    assert _run(root, GRAPH_STEP) == [before, first_folder]


def test_the_folder_is_inside_a_user_set_numba_cache_dir_and_children_key_on_their_own(tmp_path):
    root = _package_copy(tmp_path)
    user = tmp_path / "numba-cache"
    script = "from somite import _jit; print(_jit.KERNEL_CACHE)"
    (folder,) = _run(root, script, NUMBA_CACHE_DIR=str(user))
    assert Path(folder).parent == user / "somite-kernels"
    # A child process inherits what its somite parent set: it still keys on its own sources.
    (root / "somite" / "_math.py").write_text((root / "somite" / "_math.py").read_text() + "\n")
    (child,) = _run(root, script, NUMBA_CACHE_DIR=folder, SOMITE_KERNEL_CACHE=folder)
    assert Path(child).parent == Path(folder).parent and child != folder


def test_this_process_uses_and_holds_its_folder():
    assert os.environ["NUMBA_CACHE_DIR"] == str(_jit.KERNEL_CACHE)
    # Its name is the sources' key when this process started (the files may have changed since).
    assert len(_jit.KERNEL_CACHE.name) == 16 and _jit.KERNEL_CACHE.parent == _jit.cache_base()
    lock = open(_jit.KERNEL_CACHE / ".in-use", "a")
    with lock, pytest.raises(OSError):
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)


def test_prune_keeps_the_current_the_held_and_the_most_recently_used(tmp_path):
    folders = {}
    for age, name in enumerate(["current", "recent", "older", "held", "oldest"]):
        folder = tmp_path / name
        folder.mkdir()
        (folder / ".in-use").touch()
        os.utime(folder / ".in-use", (1e9 - age * 100, 1e9 - age * 100))
        folders[name] = folder
    with open(folders["held"] / ".in-use", "a") as held:
        fcntl.flock(held, fcntl.LOCK_SH)
        removed = _jit.prune(tmp_path, folders["current"], kept=2)
    assert removed == [folders["oldest"]]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["current", "held", "older", "recent"]


def _somite_imports(path: Path) -> set[Path]:
    """The files of the somite modules that ``path`` imports (anywhere in it)."""
    package = path.relative_to(SOURCE).parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            module = [*package[:len(package) - node.level + 1], *(node.module or "").split(".")]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("somite"):
            module = node.module.split(".")[1:]
        else:
            continue
        module = [part for part in module if part]
        names = [alias.name for alias in node.names]
        for target in [module, *([*module, name] for name in names)]:
            for candidate in (SOURCE.joinpath(*target).with_suffix(".py"),
                              SOURCE.joinpath(*target, "__init__.py")):
                if target and candidate.is_file():
                    found.add(candidate)
    return found


KERNEL_MARKS = ("njit", "uncounted", "overload", "intrinsic")


def test_the_key_covers_every_kernel_and_what_it_imports():
    """Every module that defines a compiled function, and every module those import (what a
    kernel can call or read as a constant), is among the sources the cache is keyed on."""
    sources = set(_jit.kernel_sources())
    todo = [p for p in SOURCE.rglob("*.py") if any(m in p.read_text() for m in KERNEL_MARKS)
            and p.name != "_jit.py"]
    assert SOURCE / "sim" / "physics.py" in todo
    # The CUDA kernel caches nothing on disk; were it to, its folder would be this one too.
    assert SOURCE / "tasks" / "cuda_batch.py" in sources
    seen = set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        assert path in sources, f"{path} is read by a kernel, but not in _jit.kernel_sources()"
        todo += _somite_imports(path)


def test_processes_that_need_a_kernel_on_a_cold_cache_compile_it_once(tmp_path):
    """The second process waits for the first's compile and loads it from the cache."""
    root = _package_copy(tmp_path)
    script = GRAPH_STEP + "print(sum(graph_step.stats.cache_hits.values()))\n"
    environ = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_DIR", "SOMITE_KERNEL_CACHE")}
    environ["PYTHONPATH"] = str(root)
    both = [subprocess.Popen([sys.executable, "-c", script], cwd=root, env=environ,
                             stdout=subprocess.PIPE, text=True) for _ in range(2)]
    outputs = [process.communicate(timeout=600)[0].split() for process in both]
    assert [process.returncode for process in both] == [0, 0]
    assert {out[0] for out in outputs} == {repr(0.46211715726000974)}
    assert sorted(out[2] for out in outputs) == ["0", "1"]


def test_a_cache_that_cannot_be_written_costs_a_compile_not_the_run(tmp_path):
    """Under a file size limit (as tests/test_api_checks.py runs evolve) the cache's data file
    cannot be written: the kernel still runs, and nothing of it is loaded later."""
    root = _package_copy(tmp_path)
    limited = ("import resource; resource.setrlimit(resource.RLIMIT_FSIZE, (2000, 2000))\n"
               + GRAPH_STEP)
    value, _ = _run(root, limited)
    assert value == repr(0.46211715726000974)
