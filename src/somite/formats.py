"""somite's file formats, each a name and a version: written at the head of its JSON files and
checked, on reading, here and nowhere else.

A file starts ``{"format": NAME, "version": N, ...}`` (:meth:`FileFormat.header`). A reader
calls :meth:`FileFormat.check`, which refuses, in one line, a file that is not a JSON object, of
another format, or of a version this somite does not read (an older one, or one written by a
newer somite). Tolerant readers (a cache, the manifest of a run folder) ask
:meth:`FileFormat.matches` and treat a foreign file as missing.

Two layouts of the error, as the readers name what they read:

- by key (``field`` not given): ``version=2: unsupported; this somite reads genome version 1``,
  with ``prefix`` before the key (``campaign.version=2: ...``);
- by file (``field`` and ``where`` given, for files also named in options, such as a
  partition): ``partition='p.json': version 2 unsupported; this somite reads partition
  version 1``, ``partition='p.json': not a partition file (format 'somite-genome'; expected
  'somite-partition')``.

Every format is listed in :data:`FORMATS`; a new version of a format changes its entry here and
the code that reads the new fields.
"""

from __future__ import annotations

from dataclasses import dataclass

from .errors import bad


@dataclass(frozen=True)
class FileFormat:
    """One file format: ``name`` (the ``format`` value), ``version`` (None: the file has no
    version) and ``what`` the file holds, in words; ``older``: the reason given for a version
    this somite no longer reads, if not the usual one (``{what}`` and ``{version}`` filled in)."""

    name: str
    version: int | None
    what: str
    older: str = ""

    def header(self) -> dict:
        """The head of a file of this format: ``{"format": ..., "version": ...}``."""
        if self.version is None:
            return {"format": self.name}
        return {"format": self.name, "version": self.version}

    def problem(self, data) -> tuple[str, object, str] | None:
        """(key, value, reason) of what makes ``data`` not a file of this format, or None."""
        if not isinstance(data, dict):
            return ("", type(data).__name__, "expected a JSON object")
        if data.get("format") != self.name:
            return ("format", data.get("format"), f"not a {self.what} file; expected {self.name!r}")
        if self.version is None:
            return None
        version = data.get("version")
        if type(version) is int and version == self.version:
            return None
        reads = f"this somite reads {self.what} version {self.version}"
        if type(version) is int and version > self.version:
            return ("version", version, f"written by a newer somite; {reads} (upgrade somite)")
        older = self.older.format(what=self.what, version=self.version)
        return ("version", version, older or f"unsupported; {reads}")

    def matches(self, data) -> bool:
        """Whether ``data`` is a file of this format and version."""
        return self.problem(data) is None

    def check(
        self, data, field: str | None = None, where: str | None = None, prefix: str = ""
    ) -> dict:
        """``data`` if it is a file of this format and version, else a one-line error (see
        the module docstring for its two layouts)."""
        problem = self.problem(data)
        if problem is None:
            return data
        key, value, reason = problem
        if field is not None:
            if key == "version":
                raise bad(field, where, f"version {value!r} {reason}")
            shown = f"format {value!r}; expected {self.name!r}" if key else reason
            raise bad(field, where, f"not a {self.what} file ({shown})")
        raise bad(f"{prefix}{key}" if key else self.what, value, reason)


def known_keys(data, allowed: tuple[str, ...], field: str) -> None:
    """Refuse a key of the JSON object ``data`` (at ``field``) that is not ``allowed``: a
    reader that skipped it would drop what the writer meant (a misspelt ``edgse``), or carry
    megabytes of it along unread. Not an object: left to the reader's own check."""
    if isinstance(data, dict):
        for key in data:
            if key not in allowed:
                raise bad(f"{field}.{key}" if field else key, data[key],
                          f"unknown key; {field or 'the file'} has {', '.join(allowed)}")


GENOME = FileFormat("somite-genome", 1, "genome")
MODULE = FileFormat("somite-module", 1, "module")
PARTITION = FileFormat("somite-partition", 1, "partition")
# Version 3 (issue 10): the checkpoint holds its run's fingerprint
# (:func:`somite.experiments.runner.run_fingerprint`). Version 2 (issue 9): two generators
# (variation, evaluation) instead of one. An older checkpoint cannot be resumed: it cannot be
# tied to its run, or its draws are not version 3's.
CHECKPOINT = FileFormat(
    "somite-checkpoint",
    3,
    "checkpoint",
    older="cannot be resumed by this somite (it reads {what} version {version}); start the run "
    "again",
)
MANIFEST_FILE = FileFormat("somite-run-manifest", None, "run manifest")
CAMPAIGN = FileFormat("somite-campaign", 1, "campaign")
CAMPAIGN_PACK = FileFormat("somite-campaign-pack", 1, "campaign pack")
RUN_PHYSICS = FileFormat("somite-run-physics", 1, "run physics")
REPORT = FileFormat("somite-report", 1, "report")
REPORT_CACHE = FileFormat("somite-report-cache", 1, "report cache")

FORMATS = {
    f.name: f
    for f in (GENOME, MODULE, PARTITION, CHECKPOINT, MANIFEST_FILE, CAMPAIGN, CAMPAIGN_PACK,
              RUN_PHYSICS, REPORT, REPORT_CACHE)
}
"""Every file format somite writes, by name."""


__all__ = [
    "CAMPAIGN",
    "CAMPAIGN_PACK",
    "CHECKPOINT",
    "FORMATS",
    "GENOME",
    "MANIFEST_FILE",
    "MODULE",
    "PARTITION",
    "REPORT",
    "REPORT_CACHE",
    "RUN_PHYSICS",
    "FileFormat",
    "known_keys",
]
