"""Run directories: an evolutionary run on disk, with checkpoints and exact resume.

A run directory holds

- ``config.json``: the resolved :class:`~somite.experiments.config.RunConfig`, flat;
- ``log.csv``: one row per generation (:data:`LOG_COLUMNS`);
- ``bests.jsonl``: the best genome of every generation, one compact JSON object a line;
- ``best.json``: the best genome so far with its body (any command that takes a genome reads it);
- ``checkpoint.json``: population, fitness, origins and both generators' states, written
  atomically at generation 0, every ``checkpoint_every`` generations and at the end, sealed
  with a checksum and a digest of every log row and best up to it
  (:func:`~.history.seal_checkpoint`);
- ``physics.json``: the physics version the run started under, and every resume under another
  one that the user forced (:mod:`.physics`); a resume under another physics is refused;
- ``manifest.json``: the files above that the run wrote (``transfer.csv`` too, for a
  re-optimisation), written before them: ``--force`` deletes these and refuses a folder
  holding anything else;
- ``.somite.lock``, while the run goes on (:mod:`somite.experiments.lock`).

``--resume`` first checks the whole history (:mod:`.history`: every row and line readable,
generations consecutive from 0, the checkpoint consistent with the log and ``config.json``) and
refuses a damaged one in one line; then it cuts ``log.csv`` and ``bests.jsonl`` back to the
checkpoint's generation and goes on from there; as every random draw comes from the
checkpointed generators, the resumed run writes the same rows and the same best genome as one
that was never interrupted. A run killed before its first checkpoint (during generation 0)
starts again on ``--resume``, which for a seeded run is the same thing (one killed before it
wrote ``config.json`` needs its options again); temporary files of writes a kill cut short are
removed. ``--resume --generations N`` rewrites ``config.json`` with N.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable
from pathlib import Path

from .._io import (
    CHECK_PREFIX,
    TEMPORARY,
    check_output_file,
    check_output_folder,
    csv_text,
    discard,
    make_folder,
    read_json,
    read_text,
    reason,
    temporary_name,
    write_atomic,
)
from ..brain.genome import Genome
from ..errors import bad
from ..evolution.ea import GraphEA
from ..formats import CHECKPOINT, MANIFEST_FILE
from ..sim.body import Body
from .config import RunConfig, resolve
from .history import (
    HISTORY_FILES,
    Digests,
    History,
    check_checkpoint,
    check_checksum,
    check_history,
    read_history,
    seal_checkpoint,
)
from .lock import LOCK_NAME, RunLock
from .logfile import LOG_COLUMNS, format_row
from .physics import PHYSICS_FILE, check_resume, force_record, started

RUN_FILES = ("config.json", "log.csv", "bests.jsonl", "best.json", "checkpoint.json",
             "transfer.csv", PHYSICS_FILE)
MANIFEST = "manifest.json"
"""``manifest.json`` lists the files a run wrote: the only ones ``--force`` deletes."""
def _is_temporary(name: str) -> bool:
    """A temporary file of a run file's write, or of an output folder's check."""
    match = TEMPORARY.fullmatch(name)
    return bool(match and match["name"] in (*RUN_FILES, MANIFEST)) or name.startswith(
        CHECK_PREFIX)


def run_fingerprint(config: RunConfig, body: Body) -> str:
    """A hash of everything that decides a run's draws: its resolved configuration but the
    number of generations (``--resume`` may change that) and its body. A checkpoint is
    resumed only in the run whose fingerprint it carries."""
    options = {k: v for k, v in config.to_dict().items() if k != "generations"}
    text = json.dumps({"config": options, "body": body.to_dict()}, sort_keys=True,
                      separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def save_checkpoint(path: Path, ea: GraphEA, config: RunConfig,
                    digests: Digests | None = None) -> None:
    """Write the checkpoint of ``ea``, sealed (:func:`~.history.seal_checkpoint`) with the
    history's ``digests`` kept as it was written, or else read from the run's files."""
    data = {**CHECKPOINT.header(),
            "run": run_fingerprint(config, ea.body), **ea.state()}
    write_atomic(path, json.dumps(seal_checkpoint(data, path.parent, digests),
                                  separators=(",", ":")))


def load_checkpoint(path: Path, config: RunConfig, logged: int) -> GraphEA:
    """Read a checkpoint of the run ``config`` whose ``log.csv`` holds ``logged`` rows;
    anything missing, damaged, of another version, of another run or at a generation the log
    does not reach is a one-line error."""
    if not path.is_file():
        raise bad("resume", str(path.parent), "no checkpoint.json in this run directory")
    text = read_text(path, "checkpoint")
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise bad("checkpoint", str(path), f"damaged checkpoint ({error})") from None
    CHECKPOINT.check(data, "checkpoint", str(path))
    generation = data.get("generation")
    if not isinstance(generation, int) or isinstance(generation, bool) or not (
        0 <= generation < logged
    ):
        held = f"generations 0 to {logged - 1}" if logged else "no generation"
        raise bad("checkpoint.generation", generation, f"log.csv holds {held}")
    check_checksum(data, path)
    try:
        ea = GraphEA.restore(data, config.ga, config.setup.partition)
    except (ValueError, KeyError, TypeError, AttributeError, IndexError, OverflowError,
            RecursionError) as error:
        raise bad("checkpoint", str(path), f"damaged checkpoint ({error})") from None
    if data.get("run") != run_fingerprint(config, ea.body):
        raise bad("checkpoint", str(path), "belongs to another run (its configuration or body "
                  "is not this directory's config.json)")
    check_history(data, path)
    return ea


def _json_number(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


class RunDirectory:
    """The files of one run; appends rows as generations finish."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.lock = RunLock(self.path)
        self.digests: Digests | None = None
        """The digests of the lines of log.csv and bests.jsonl, kept from the moment this
        object wrote those files whole (a new run, a resume's cut-back); None before, and
        a checkpoint is then sealed from the files."""

    def locked(self) -> RunDirectory:
        """Create the folder if need be and take its lock (see :mod:`.lock`); a context
        manager that releases it."""
        check_output_folder(self.path)
        self._created = not self.path.exists()
        make_folder(self.path)
        self.lock.acquire()
        return self

    def __enter__(self) -> RunDirectory:
        return self

    def __exit__(self, *exc) -> None:
        self.lock.release()
        if exc[0] is not None and getattr(self, "_created", False):
            # Refused before it wrote anything: leave no empty directory behind.
            try:
                self.path.rmdir()
            except OSError:
                pass

    def file(self, name: str) -> Path:
        return self.path / name

    def has_run(self) -> bool:
        return any(self.file(name).exists() for name in RUN_FILES)

    def remove_temporary(self) -> None:
        """Delete the temporary files a killed writer of run files left (call it locked:
        then no live writer owns them)."""
        for path in self.path.iterdir():
            if _is_temporary(path.name) and path.is_file():
                path.unlink(missing_ok=True)

    def manifest(self) -> list[str]:
        """The files this run wrote (or is about to), from ``manifest.json``; [] without
        one (or with one that is not somite's)."""
        return self._read_manifest() or []

    def _read_manifest(self) -> list[str] | None:
        try:
            data = json.loads(self.file(MANIFEST).read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError):
            return None
        if not MANIFEST_FILE.matches(data) or not isinstance(data.get("files"), list):
            return None
        return [n for n in data["files"] if isinstance(n, str) and n in RUN_FILES]

    def record(self, *names: str) -> None:
        """Add ``names`` to the manifest; call it before writing them, so that a kill between
        the two leaves no file of the run unlisted."""
        listed = self.manifest()
        if all(n in listed for n in names) and self.file(MANIFEST).is_file():
            return
        data = {**MANIFEST_FILE.header(), "files": [*listed, *(n for n in names
                                                                 if n not in listed)]}
        write_atomic(self.file(MANIFEST), json.dumps(data) + "\n")

    def foreign(self) -> str | None:
        """The first entry of the folder that is not a file this run's manifest lists (nor
        the manifest, the lock or a temporary file of a run file), or None."""
        listed = self.manifest()
        own = {LOCK_NAME, *listed}
        if listed:
            own.add(MANIFEST)
        for path in sorted(self.path.iterdir()):
            if _is_temporary(path.name):
                continue
            if path.name not in own or path.is_symlink() or not path.is_file():
                return path.name
        return None

    def remove_own(self) -> None:
        """Delete the files the manifest lists (and temporary files), nothing else; all of
        them or none. A read-only (or immutable) one, or the manifest that is rewritten next,
        is refused before anything is deleted; then the files are moved aside (renamed to
        temporary names) and deleted only once all are: one that cannot be moved (the folder's
        sticky bit, an append-only file, ...) puts the others back, and is a one-line error."""


        own = [self.file(n) for n in self.manifest()]
        own = [p for p in own if p.is_file() and not p.is_symlink()]
        temporary = [p for p in self.path.iterdir() if _is_temporary(p.name) and p.is_file()]
        manifest = [self.file(MANIFEST)] if self.file(MANIFEST).is_file() else []
        for path in (*own, *manifest, *temporary):
            if not os.access(path, os.W_OK):
                raise bad("out", str(self.path), f"its {path.name} is read-only (or immutable), "
                          "so the run cannot be replaced; nothing was deleted: make it writable "
                          "or move the run away")
        self.remove_temporary()
        moved: list[tuple[Path, Path]] = []
        for path in own:
            aside = self.file(temporary_name(path.name))
            try:
                os.rename(path, aside)
            except OSError as error:
                for back, where in reversed(moved):
                    try:
                        os.rename(back, where)
                    except OSError:
                        pass
                raise bad("out", str(self.path), f"cannot delete its {path.name} "
                          f"({reason(error)}), so the run cannot be replaced; nothing was "
                          "deleted") from None
            moved.append((aside, path))
        for aside, _ in moved:
            discard(aside)  # left only if this fails: a later remove_temporary takes it

    def logged_generations(self) -> int:
        """How many complete rows ``log.csv`` holds (0 when it is missing)."""
        log = self.file("log.csv")
        if not log.is_file():
            return 0
        lines = read_text(log, "log").splitlines()
        return max(0, sum(1 for line in lines[1:] if line.count(",") == len(LOG_COLUMNS) - 1))

    def prepare_new(self, config: RunConfig, force: bool, restart: bool = False) -> None:
        """Start the run's files. ``force``: replace a run here, but refuse when the folder
        holds anything its manifest does not list. ``restart``: replace this run's own files
        (one killed before its first checkpoint), leaving anything else alone."""
        if self.file(MANIFEST).exists() and self._read_manifest() is None:
            raise bad("out", str(self.path), f"holds a {MANIFEST} that is not a somite run's")
        if force and not restart:
            name = self.foreign()
            if name is not None:
                raise bad("out", str(self.path),
                          f"holds {name}, which is not a file of the run's manifest.json; "
                          "--force deletes only those: move it away first")
        elif self.has_run() and not restart:
            raise bad("out", str(self.path), "holds a run already; use --resume or --force")
        self.remove_own()
        self.record("config.json", "log.csv", "bests.jsonl", "best.json", "checkpoint.json",
                    PHYSICS_FILE)
        self.write_config(config)  # first: a run killed before it has no options to resume
        write_atomic(self.file(PHYSICS_FILE), started())
        write_atomic(self.file("log.csv"), ",".join(LOG_COLUMNS) + "\n")
        write_atomic(self.file("bests.jsonl"), "")
        self.digests = Digests()

    def check_resumable(self) -> None:
        """Refuse, before anything is written, a run whose files a resume could not rewrite
        (read-only, immutable) or whose manifest is not somite's: the refusal used to come at
        the first checkpoint, after config.json was rewritten and log.csv appended to."""
        manifest = self.file(MANIFEST)
        if manifest.exists() and self._read_manifest() is None:
            raise bad("resume", str(manifest), "not a somite run manifest (another format or "
                      "damaged); nothing was changed")
        for name in (*RUN_FILES, MANIFEST):
            if self.file(name).exists():
                check_output_file(self.file(name), "resume")
        check_output_folder(self.path, "resume")

    def write_config(self, config: RunConfig) -> None:
        write_atomic(self.file("config.json"), json.dumps(config.to_dict(), indent=2) + "\n")

    def saved_options(self) -> dict:
        """``config.json`` as written (not resolved)."""
        path = self.file("config.json")
        if not path.is_file():
            raise bad("resume", str(self.path), "no config.json in this run directory")
        data = read_json(path, "config")
        if not isinstance(data, dict):
            raise bad("config", str(path), f"expected a JSON object, not {type(data).__name__}")
        return data

    def saved_config(self) -> RunConfig:
        return resolve(self.saved_options())

    def cut_back(self, generation: int, history: History) -> None:
        """Keep the log rows and best genomes up to ``generation`` (``history``, checked by
        :func:`~.history.read_history`): the rest the resumed run writes again."""
        self.digests = None  # until both files are written whole again
        log = csv_text(LOG_COLUMNS, history.rows[: generation + 1])
        write_atomic(self.file("log.csv"), log)
        kept = history.bests[: generation + 1]
        bests = "".join(json.dumps(e, separators=(",", ":")) + "\n" for e in kept)
        write_atomic(self.file("bests.jsonl"), bests)
        digests = Digests()
        digests.wrote("log", log.split("\n", 1)[1])
        digests.wrote("bests", bests)
        self.digests = digests

    def append(self, row: dict, best: Genome) -> None:
        """Write a generation's log row and its best genome. A failed append (a full disk)
        is one line; the torn line it may leave is the run's own, which ``--resume`` repairs."""
        entry = {
            "generation": row["generation"],
            "velocity": _json_number(row["best_velocity"]),
            "operator": row["best_operator"],
            "genome": json.loads(best.to_compact()),
        }
        for name, line in (("log", format_row(row)),
                           ("bests", json.dumps(entry, separators=(",", ":")))):
            file = HISTORY_FILES[name]
            try:
                with open(self.file(file), "a", encoding="utf-8") as handle:
                    handle.write(line + "\n")
            except OSError as error:
                self.digests = None  # the file holds what no digest says: read it again
                raise bad("out", str(self.path), f"cannot append to its {file} "
                          f"({error.strerror or error}); --resume continues from the last "
                          "checkpoint") from None
            if self.digests is not None:
                self.digests.wrote(name, line + "\n")

    def save(self, ea: GraphEA, config: RunConfig) -> None:
        ea.best.save(self.file("best.json"))
        save_checkpoint(self.file("checkpoint.json"), ea, config, self.digests)


Progress = Callable[[GraphEA, dict], None]


def step(ea: GraphEA, task, config: RunConfig) -> dict:
    """One generation: ask, evaluate with ``task`` on the EA's evaluation generator, tell, and
    (when due) the best's mean v_x on the validation terrains. Returns the log row."""
    genomes = ea.ask()
    fitness, non_finite = task.evaluate_counted(genomes, rng=ea.rng_evaluation)
    row = ea.tell(genomes, fitness, non_finite=int(non_finite.sum()))
    if config.validation_due(ea.generation):
        row["validation_velocity"] = task.validation_velocity(ea.best)
    return row


def evolve(
    config: RunConfig,
    out: str | Path | RunDirectory,
    resume: bool = False,
    force: bool = False,
    progress: Progress | None = None,
    start: Genome | None = None,
    backend: str = "cpu",
    force_physics: bool = False,
) -> GraphEA:
    """Run (or resume) an evolution into the run directory ``out``; returns the EA at the end.

    With ``start`` (a re-optimisation), the first population is ``start`` and mutants of it;
    its shape must be the configuration's. ``progress`` is called after every generation with
    the EA and the log row. The run directory is locked for the run (a second process is
    refused); a caller that needs it locked for longer passes a locked :class:`RunDirectory`.
    ``backend`` (``cpu``, ``cuda``) is where the episodes run. A resume under another physics
    than the run's is refused unless ``force_physics`` (:mod:`.physics`).
    """
    if isinstance(out, RunDirectory) and out.lock.held:
        return _evolve(config, out, resume, force, progress, start, backend, force_physics)
    with RunDirectory(out.path if isinstance(out, RunDirectory) else out).locked() as run_dir:
        return _evolve(config, run_dir, resume, force, progress, start, backend, force_physics)


def _evolve(config: RunConfig, run_dir: RunDirectory, resume: bool, force: bool,
            progress: Progress | None, start: Genome | None, backend: str,
            force_physics: bool = False) -> GraphEA:
    ea = open_run(config, run_dir, resume, force, start, force_physics)
    task = config.task(ea.body, backend)
    while ea.generation < config.generations:
        finish_generation(ea, step(ea, task, config), run_dir, config, progress)
    return ea


def open_run(config: RunConfig, run_dir: RunDirectory, resume: bool, force: bool,
             start: Genome | None, force_physics: bool = False) -> GraphEA:
    """The EA of a new run (its files started) or of a resumed one (its files cut back to
    the checkpoint); ``run_dir`` must be locked."""
    restart = False
    if resume:
        run_dir.check_resumable()
        run_dir.remove_temporary()
        if not run_dir.file("checkpoint.json").exists():
            # Killed before its first checkpoint (during generation 0): as every draw comes
            # from the seed, starting again is resuming. More than generation 0 logged
            # means the checkpoint went missing, and the log is not thrown away.
            logged = run_dir.logged_generations()
            if logged > 1:
                raise bad("resume", str(run_dir.path),
                          f"no checkpoint.json, but log.csv holds {logged} generations")
            resume, restart = False, True
    if resume:
        history = read_history(run_dir.path)
        ea = load_checkpoint(run_dir.file("checkpoint.json"), config, len(history.rows))
        check_checkpoint(history, ea, config.ga.population, run_dir.file("checkpoint.json"))
        if ea.generation > config.generations:
            raise bad("generations", config.generations,
                      f"the checkpoint is at generation {ea.generation} already")
        forced = check_resume(run_dir.path, force_physics, ea.generation)
    else:
        if start is None and config.start:
            raise bad("start", config.start, "names a start genome, but none was given: "
                      "pass it (evolve(..., start=genome)) or use `somite reoptimize`")
        body = config.body() if start is None else start.body
        if body.shape != config.body().shape:
            raise bad("shape", config.shape,
                      f"the start genome's shape is {body.shape.grid_string()}")
        ea = GraphEA(body, seed=config.seed, start=start, config=config.ga,
                     partition=config.setup.partition)
    config.task(ea.body)  # refuses a body the task cannot run before any file is touched
    if resume:
        if forced is not None:
            run_dir.record(PHYSICS_FILE)
            force_record(run_dir.path, forced)
        run_dir.cut_back(ea.generation, history)
        # --resume --generations N; compared as written, so that a resume resolves nothing
        if run_dir.saved_options() != json.loads(json.dumps(config.to_dict())):
            run_dir.write_config(config)
    else:
        run_dir.prepare_new(config, force, restart)
    return ea


def finish_generation(ea: GraphEA, row: dict, run_dir: RunDirectory, config: RunConfig,
                      progress: Progress | None) -> None:
    """Write a told generation's row and best; report it; checkpoint when due."""
    run_dir.append(row, ea.best)
    if progress is not None:
        progress(ea, row)
    if ea.generation % config.checkpoint_every == 0 or ea.generation in (
        0, config.generations
    ):
        run_dir.save(ea, config)
