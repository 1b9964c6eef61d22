"""``somite campaign``: run the paper's experiments (or a campaign file) on Dask, resumably."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..errors import bad
from .common import finite_float

# The built-ins' names are `campaign list`'s to give: importing the campaigns here would load
# the simulator for every command's --help.
HELP = ("Run a campaign of experiments (a built-in, which `somite campaign list` lists, or a "
        "TOML file) on Dask; list the built-ins; show a campaign directory's tasks; pack a "
        "campaign's resumable state into one file and unpack it elsewhere.")
NEXT_SHOWN = 3
"""How many of the tasks next to start ``campaign status`` names."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", required=True, parser_class=type(parser))
    run = sub.add_parser("run", help="run (or --resume) a campaign into a directory")
    run.add_argument("campaign", nargs="?",
                     help="a built-in campaign (`somite campaign list`; paper:N, paper-rq1:N "
                     "and lengths:N for N seeds; paper:N grows a paper-rq1 folder with "
                     "--resume) or a "
                     "campaign TOML file; with --resume it may be left out")
    run.add_argument("--out", required=True, help="campaign directory")
    run.add_argument("--resume", action="store_true",
                     help="continue the campaign in --out: finished tasks are skipped, "
                     "unfinished runs resume from their checkpoints")
    run.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                     help="an existing Dask scheduler (default: a local cluster on this "
                     "machine); its workers need the campaign directory at the same path")
    run.add_argument("--workers", type=int,
                     help="local worker processes (default: cores / threads)")
    run.add_argument("--threads", type=int,
                     help="Numba threads per task (default 1, or cores / --workers)")
    run.add_argument("--quiet", action="store_true", help="no progress view")
    run.add_argument("--yes", action="store_true",
                     help="start a campaign estimated at more than 12 h on this machine's "
                     "cores (refused without it; not checked with --scheduler)")
    run.add_argument("--force-physics", action="store_true",
                     help="with --resume: resume runs that started under another physics "
                     "version than this somite's (refused without it); each such run's "
                     "physics.json records it")
    listing = sub.add_parser("list", help="the built-in campaigns (or the campaigns named), "
                             "their tasks, robot-control-steps and time, before running any")
    listing.add_argument("campaigns", nargs="*", metavar="CAMPAIGN",
                         help="built-in names or campaign TOML files (default: every built-in)")
    status = sub.add_parser("status", help="the table of a campaign directory's tasks")
    status.add_argument("directory", help="campaign directory")
    pack = sub.add_parser(
        "pack", help="write a stopped campaign's whole resumable state into one compressed file",
        description="Write a campaign directory (stopped, or finished) into one compressed file "
        "that `somite campaign unpack` restores: every file as it is, genomes and logs as "
        "binary arrays, an evolve run's bests thinned to every 10th generation and the last "
        "10 (the report does not read the others; a resume needs none of them). `campaign run "
        "--resume` on the unpacked folder goes on exactly as it would have here.")
    pack.add_argument("directory", help="campaign directory")
    pack.add_argument("--out", required=True, help="the pack file to write (replaced "
                      "atomically if it exists)")
    pack.add_argument("--quiet", action="store_true", help="no progress lines")
    unpack = sub.add_parser(
        "unpack", help="restore a campaign directory from a pack",
        description="Restore a campaign directory from a file `somite campaign pack` wrote; "
        "`somite campaign run --resume --out DIR` then continues it. A pack is checked as it "
        "is read (a damaged or crafted one is refused, nothing written), and unpacks to at "
        "most --max-gib GiB.")
    unpack.add_argument("pack", help="pack file")
    unpack.add_argument("--out", required=True, help="campaign directory to create (new or "
                        "empty)")
    unpack.add_argument("--max-gib", type=finite_float("max-gib"), default=2.0, metavar="GIB",
                        help="the most the pack's files may add up to, in GiB (default 2; "
                        "the paper's campaign is 0.03)")
    unpack.add_argument("--quiet", action="store_true", help="no progress lines")


def run(args: argparse.Namespace) -> int:
    return {"run": _run, "list": _list, "status": _status, "pack": _pack,
            "unpack": _unpack}[args.action](args)


def _say(quiet: bool):
    return (lambda text: None) if quiet else (lambda text: print(text, file=sys.stderr,
                                                                  flush=True))


def _pack(args: argparse.Namespace) -> int:
    from ..campaigns.pack import pack

    done = pack(args.directory, args.out, _say(args.quiet))
    if not args.quiet:
        print(f"{args.out}: {done.bytes / 1e6:.2f} MB ({done.files} files of "
              f"{done.size / 1e6:.2f} MB; bests kept {done.bests_kept}, thinned "
              f"{done.bests_thinned})")
    return 0


def _unpack(args: argparse.Namespace) -> int:
    from ..campaigns.unpack import unpack

    if not 0 < args.max_gib <= 2**20:
        raise bad("max-gib", args.max_gib, "must be above 0 and at most 1048576 (1 PiB)")
    index = unpack(args.pack, args.out, _say(args.quiet), max_bytes=int(args.max_gib * 2**30))
    if not args.quiet:
        print(f"campaign {index.get('campaign')!r} in {args.out} ({len(index['files'])} "
              f"files); `somite campaign run --resume --out {args.out}` continues it")
    return 0


def load_campaign(name: str):
    """A built-in campaign by name, or a campaign TOML file."""
    from ..campaigns.builtin import BUILTINS, builtin, is_builtin
    from ..campaigns.spec import load

    if is_builtin(name):
        return builtin(name)
    if not name.endswith(".toml") and not Path(name).is_file():
        raise bad("campaign", name, f"no such built-in campaign ({', '.join(BUILTINS)}) or "
                  "campaign file")
    return load(name)


def _run(args: argparse.Namespace) -> int:
    from contextlib import nullcontext

    from ..campaigns import directory as campaign_dir
    from ..campaigns.executor import check_scheduler, connect, execute, sizing
    from ..campaigns.expansion import expand
    from ..experiments.lock import RunLock

    # Bad sizes and addresses are refused before anything is written.
    sizing(args.workers, args.threads)
    check_scheduler(args.scheduler)
    if args.campaign is None and not args.resume:
        raise bad("campaign", None, "name a campaign (a built-in of `somite campaign list`, or "
                  "a .toml file)")
    if args.force_physics and not args.resume:
        raise bad("force_physics", True, "only with --resume (a new campaign runs under this "
                  "somite's physics)")
    doc = None
    if args.campaign is not None:
        campaign = load_campaign(args.campaign)
        doc = campaign_dir.document(campaign, expand(campaign))
    out = Path(args.out)
    # Refused before its directory is created or locked; checked again once locked.
    planned = campaign_dir.prepare(out, doc, args.resume, write=False)
    campaign_dir.check_runnable(planned)
    # Runs of another physics are refused before anything starts, as each run's resume would.
    campaign_dir.physics_to_force(out, planned, args.force_physics)
    # Connected (or the local cluster started) before anything is written: a scheduler that
    # cannot be reached leaves no campaign.json, which would refuse the next attempt.
    left = [t for t in planned["tasks"] if not campaign_dir.finished(out, t)]
    if args.scheduler is None:  # a cluster's size is its own; a local one's is this machine
        from ..budget import check_time, hours
        from ..campaigns.executor import cores
        from ..campaigns.kinds import estimate

        check_time("this campaign", hours(sum(estimate(t) for t in left), cores=cores()),
                   args.yes)
    pending = bool(left)
    with connect(args.scheduler, args.workers, args.threads) if pending else nullcontext() \
            as connection:
        out.mkdir(parents=True, exist_ok=True)
        with RunLock(out):
            doc = campaign_dir.prepare(out, doc, args.resume)
            _force_physics(out, doc, args.force_physics)
            with LiveView(out, doc, args.quiet) as view:
                outcome = execute(out, doc, args.scheduler, args.workers, args.threads,
                                  watch=view.update, connection=connection)
    for task_id, reason in outcome.failed.items():
        sys.stderr.write(f"somite campaign: task {task_id} failed: {reason}\n")
    if outcome.skipped:
        sys.stderr.write(f"somite campaign: {len(outcome.skipped)} tasks not run, as a task "
                         "they need failed\n")
    if not args.quiet:
        ran = set(outcome.ran)
        steps = sum((campaign_dir.state(out, t)["done"] or {}).get("robot_control_steps", 0)
                    for t in doc["tasks"] if t["id"] in ran)
        rate = f" ({steps / outcome.wall_s:,.0f} robot-control-steps/s)" if steps else ""
        print(f"{len(outcome.ran)} tasks run in {outcome.wall_s:.1f} s{rate}; "
              f"`somite campaign status {out}` lists them")
    return 1 if outcome.failed or outcome.skipped else 0


def _force_physics(out: Path, doc: dict, force: bool) -> None:
    """Record the forced resumes under this physics in each run's physics.json (the runs then
    resume on the workers as runs of this physics)."""
    from ..campaigns import directory as campaign_dir
    from ..experiments.physics import PHYSICS_FILE, force_record
    from ..experiments.runner import RunDirectory

    for folder, text in campaign_dir.physics_to_force(out, doc, force):
        with RunDirectory(folder).locked() as run_dir:
            run_dir.record(PHYSICS_FILE)
            force_record(folder, text)


def _list(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..budget import STEPS_PER_CORE_SECOND, about, hours
    from ..campaigns.builtin import BUILTINS
    from ..campaigns.executor import cores
    from ..campaigns.expansion import expand
    from ..campaigns.kinds import TASK_KINDS, estimate

    n = cores()
    rows = []
    names = args.campaigns or list(BUILTINS)
    # Every file read and checked before a line is printed: a bad one is one line, no table.
    expanded = [expand(load_campaign(name)) for name in names]
    for name, tasks in zip(names, expanded):
        kinds = [sum(t["kind"] == k for t in tasks) for k in TASK_KINDS]
        steps = sum(estimate(t) for t in tasks)
        rows.append([name, str(len(tasks)), *map(str, kinds), f"{steps:.2e}",
                     about(hours(steps, cores=n) * 3600)])
    console = Console()
    title = "built-in campaigns" if not args.campaigns else "campaigns"
    console.print(_fit(console, lambda compact: _list_table(rows, list(TASK_KINDS), n, compact,
                                                            title)))
    # Through rich, so that the note wraps at the terminal's width too.
    console.print(f"time: the simulation alone (not Dask's start or Numba's first compilation) "
                  f"at {STEPS_PER_CORE_SECOND:,} robot-control-steps/s a core (BENCHMARKS.md, "
                  f"the worm) on this machine's {n} cores; `somite bench` measures the rate "
                  "here")
    return 0


def _list_table(rows: list[list[str]], kinds: list[str], n: int, compact: bool,
                title: str = "built-in campaigns"):
    """The campaigns' table; ``compact``: the long headers on several lines, 80 columns hold
    it then."""
    from rich.table import Table
    from rich.text import Text

    steps = "robot-\ncontrol-\nsteps" if compact else "robot-control-steps"
    time = f"time on\n{n} cores" if compact else f"time on {n} cores"
    # A file's name is the user's text: shown as it is, never read as rich markup.
    grid = Table(title=title, **_style(compact))
    grid.add_column("campaign", overflow="fold")  # a file's path may be long: folded, not cut
    for name in ("tasks", *kinds, steps, time):
        grid.add_column(name, justify="right", no_wrap=True)
    for row in rows:
        grid.add_row(Text(row[0]), *row[1:])
    return grid


def _style(compact: bool) -> dict:
    """Table options: rich's default rules, or (``compact``) only the rule under the header and
    two spaces between columns, where the rules and padding would take 3 a column."""
    from rich import box

    if not compact:
        return {"box": box.HEAVY_HEAD}
    return {"box": box.SIMPLE_HEAD, "show_edge": False, "padding": (0, 0, 0, 1)}


def _fit(console, table):
    """``table(compact=False)`` where the terminal is wide enough for it, else
    ``table(compact=True)``: no cell is cut to "…" either way (rich would cut every column
    of a table too wide for the terminal)."""
    wide = table(False)
    # Measured unbounded: a measurement within the terminal's width is clamped to it.
    natural = console.measure(wide, options=console.options.update_width(10**6)).maximum
    return wide if natural <= console.width else table(True)


def _status(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..campaigns import directory as campaign_dir
    from ..campaigns.progress import seconds_left, snapshot, states

    directory = Path(args.directory)
    doc = campaign_dir.read(directory)
    infos = states(directory, doc)
    console = Console()
    console.print(_fit(console, lambda compact: _table(directory, doc, infos, compact)))
    now = snapshot(doc, infos)
    # Through rich, so that the line wraps at the terminal's width too.
    console.print(", ".join(f"{n} {k}" for k, n in now.counts.items()) +
                  f"; {now.fraction:.1%} of {now.steps[1]:.3g} robot-control-steps" +
                  _time_left(seconds_left(doc, infos), now.counts["running"]))
    following = _next(directory, doc, infos)
    if following:
        console.print(following)
    return 0


def _next(directory: Path, doc: dict, infos: list[dict], shown: int = NEXT_SHOWN) -> str:
    """The tasks neither finished nor running, in the order a ``campaign run --resume`` starts
    them (the runs begun first, then seed by seed), the first ``shown`` of them by name."""
    from ..campaigns.executor import priorities, submission_order

    waiting = [t for t, i in zip(doc["tasks"], infos) if i["state"] in ("partial", "queued")]
    if not waiting:
        return ""
    order = [t["id"] for t in submission_order(waiting, priorities(directory, waiting))]
    more = f" and {len(order) - shown} more" if len(order) > shown else ""
    return f"next to start: {', '.join(order[:shown])}{more}"


def _time_left(seconds: float | None, running: int) -> str:
    """The status line's estimate of the time left, at the runs' recent pace: one task at a
    time, and shared among the runs now running where several are."""
    from ..budget import about

    if not seconds:
        return ""
    text = f"; left at the runs' recent pace: {about(seconds)} one task at a time"
    if running > 1:
        text += f", {about(seconds / running)} {running} at a time"
    return text


def _duration(seconds: float) -> str:
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def _fmt(value) -> str:
    return "-" if value is None else f"{value:.3f}"


def _table(directory: Path, doc: dict, infos: list[dict], compact: bool = False):
    """The table of every task: id, kind, state, generation/total, the logged best v_x (a
    lucky draw of terrains) and the best's v_x on the validation terrains where measured.

    ``compact`` (a terminal too narrow for the whole ids, which take 44 characters in the
    built-ins): the tasks grouped under a row of their experiment, each named without it, the
    two-word headers on two lines and no space before the first column, which 80 columns hold
    (the longest built-in names just); a name still too long is folded onto a second line
    rather than cut."""
    from rich.markup import escape
    from rich.table import Table

    from .._visible import visible

    def for_terminal(text: object) -> str:
        # Control characters written out, rich's markup ([bold], [link=...]) shown as text.
        return escape(visible(text))

    # Compact, the first column starts flush left: the longest names need that character.
    # The unit on a line of its own: appended, it wrapped mid-phrase on a narrow table.
    # The name and folder are shown, never obeyed: escapes, rich markup and all.
    grid = Table(title=f"campaign {for_terminal(doc.get('name'))} in {for_terminal(directory)}"
                 "\nv_x in m/s",
                 **_style(compact), pad_edge=not compact)
    for name in ("task", "kind", "state", "generation", "best v_x", "validation v_x"):
        grid.add_column(name.replace(" ", "\n") if compact else name,
                        justify="left" if name in ("task", "kind", "state") else "right",
                        no_wrap=not compact or name != "task",
                        overflow="fold" if name == "task" else "ellipsis")
    experiment = None
    for info in infos:
        task = info["id"]
        if compact:
            group, task = info["id"].split("/", 1)
            if group != experiment:
                grid.add_row(f"{group}/", style="bold")
                experiment = group
        grid.add_row(task, info["kind"], info["state"], _generation(info), _fmt(info["best"]),
                     _fmt(info["validation"]))
    return grid


def _generation(info: dict) -> str:
    if info["generations"] is None:
        return "-"
    reached = "-" if info["generation"] is None else info["generation"]
    return f"{reached}/{info['generations']}"


_SHOWN = 12
"""Running tasks listed in the live view (a cluster may run hundreds)."""


class LiveView:
    """The progress of a running campaign: tasks done / running / queued, generations, ETA,
    the running runs and the Dask dashboard's address, live on a terminal; elsewhere (a log)
    the counts as a line every :data:`~somite.commands._progress.HEARTBEAT_SECONDS`. Nothing
    at all when ``quiet``."""

    def __init__(self, directory: Path, doc: dict, quiet: bool) -> None:
        self.directory, self.doc, self.quiet = directory, doc, quiet
        self.live = None
        self.started = time.monotonic()
        self.at_start = None
        self.last = 0.0
        self.dashboard = ""
        self.beat = None

    def __enter__(self) -> LiveView:
        if self.quiet:
            return self
        from rich.live import Live

        self.live = Live(self._render(), refresh_per_second=2)
        if not self.live.console.is_terminal:
            from ._progress import Waiting

            # A log sees nothing of a Live display until it stops: a line now and then
            # (on standard error), and the whole view at the end, as before.
            self.beat = Waiting(self._counts()).__enter__()
            return self
        self.live.start()
        return self

    def update(self, outcome) -> None:
        if self.beat is not None and time.monotonic() - self.last >= 1.0:
            self.last = time.monotonic()
            self.beat.update(text=self._counts())
        if self.live is None or self.beat is not None or time.monotonic() - self.last < 1.0:
            return
        self.last = time.monotonic()
        self.dashboard = outcome.dashboard
        self.live.update(self._render())

    def _counts(self) -> str:
        """The view's second line, alone (the counts, the share done, the ETA)."""
        return self._render(full=False)

    def _render(self, full: bool = True):
        from rich.console import Group
        from rich.text import Text

        from .._visible import visible

        from ..campaigns.progress import snapshot, states

        now = snapshot(self.doc, states(self.directory, self.doc))
        done, total = now.steps
        if self.at_start is None:
            self.at_start = done
        elapsed = time.monotonic() - self.started
        rate = (done - self.at_start) / elapsed if elapsed > 0 else 0.0
        eta = _duration((total - done) / rate) if rate > 0 else "-"
        counts = now.counts
        summary = (f"tasks: {counts['done']} done, {counts['running']} running, "
                   f"{counts['queued'] + counts['partial']} queued (of {sum(counts.values())})   "
                   f"generations {now.generations[0]}/{now.generations[1]}   "
                   f"{now.fraction:.1%} of {total:.3g} robot-control-steps   "
                   f"elapsed {_duration(elapsed)}  ETA {eta}")
        if not full:
            return summary
        lines = [
            Text(f"campaign {visible(self.doc.get('name'))} -> {visible(self.directory)}",
                 style="bold"),
            Text(summary),
            Text("dashboard: " + (self.dashboard or "none (Dask's needs bokeh: pip install "
                                  "'somite[dashboard]')")),
        ]
        for info in now.running[:_SHOWN]:
            generation = "" if info["generation"] is None else (
                f"  generation {info['generation']}/{info['generations']}"
                f"  best v_x {_fmt(info['best'])}")
            lines.append(Text(f"  {info['id']}{generation}"))
        if len(now.running) > _SHOWN:
            lines.append(Text(f"  ... and {len(now.running) - _SHOWN} more running"))
        return Group(*lines)

    def __exit__(self, *exc) -> None:
        if self.beat is not None:
            self.beat.__exit__(*exc)
            self.live.console.print(self._render())
            self.live.console.line()
        elif self.live is not None:
            self.live.update(self._render())
            self.live.stop()
            if not self.live.console.is_terminal:
                self.live.console.line()
