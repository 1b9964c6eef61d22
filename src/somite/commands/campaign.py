"""``somite campaign``: run the paper's experiments (or a campaign file) on Dask, resumably."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import bad

HELP = ("Run a campaign of experiments (built-in: paper, quick, smoke; or a TOML file) on Dask; "
        "list the built-ins; show a campaign directory's tasks.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", required=True, parser_class=type(parser))
    run = sub.add_parser("run", help="run (or --resume) a campaign into a directory")
    run.add_argument("campaign", nargs="?",
                     help="a built-in campaign (paper, quick, smoke) or a campaign TOML file; "
                     "with --resume it may be left out")
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
    sub.add_parser("list", help="the built-in campaigns, their tasks and robot-control-steps")
    status = sub.add_parser("status", help="the table of a campaign directory's tasks")
    status.add_argument("directory", help="campaign directory")


def run(args: argparse.Namespace) -> int:
    return {"run": _run, "list": _list, "status": _status}[args.action](args)


def load_campaign(name: str):
    """A built-in campaign by name, or a campaign TOML file."""
    from ..campaigns.builtin import BUDGETS, builtin
    from ..campaigns.spec import load

    if name in BUDGETS:
        return builtin(name)
    if not name.endswith(".toml") and not Path(name).is_file():
        raise bad("campaign", name, f"no such built-in campaign ({', '.join(BUDGETS)}) "
                  "or campaign file")
    return load(name)


def _run(args: argparse.Namespace) -> int:
    from ..campaigns import directory as campaign_dir
    from ..campaigns.executor import execute, sizing
    from ..campaigns.tasks import expand
    from ..campaigns.view import LiveView
    from ..experiments.lock import RunLock

    sizing(args.workers, args.threads)  # bad sizes are refused before anything is written
    if args.campaign is None and not args.resume:
        raise bad("campaign", None, "name a campaign (paper, quick, smoke or a .toml file)")
    doc = None
    if args.campaign is not None:
        campaign = load_campaign(args.campaign)
        doc = campaign_dir.document(campaign, expand(campaign))
    out = Path(args.out)
    # Refused before its directory is created or locked; checked again once locked.
    campaign_dir.prepare(out, doc, args.resume, write=False)
    out.mkdir(parents=True, exist_ok=True)
    with RunLock(out):
        doc = campaign_dir.prepare(out, doc, args.resume)
        with LiveView(out, doc, args.quiet) as view:
            outcome = execute(out, doc, args.scheduler, args.workers, args.threads,
                              watch=view.update)
    for task_id, reason in outcome.failed.items():
        sys.stderr.write(f"somite campaign: task {task_id} failed: {reason}\n")
    if outcome.skipped:
        sys.stderr.write(f"somite campaign: {len(outcome.skipped)} tasks not run, as a task "
                         "they need failed\n")
    if not args.quiet:
        print(f"{len(outcome.ran)} tasks run in {outcome.wall_s:.1f} s; "
              f"`somite campaign status {out}` lists them")
    return 1 if outcome.failed or outcome.skipped else 0


def _list(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from ..campaigns.builtin import BUDGETS, builtin
    from ..campaigns.tasks import estimate, expand

    grid = Table(title="built-in campaigns")
    for name in ("campaign", "tasks", "evolve", "reassemble", "reoptimize", "discover",
                 "robot-control-steps"):
        grid.add_column(name, justify="left" if name == "campaign" else "right")
    for name in BUDGETS:
        tasks = expand(builtin(name))
        kinds = [sum(t["kind"] == k for t in tasks)
                 for k in ("evolve", "reassemble", "reoptimize", "discover")]
        grid.add_row(name, str(len(tasks)), *map(str, kinds),
                     f"{sum(estimate(t) for t in tasks):.2e}")
    Console().print(grid)
    print("time: robot-control-steps / `somite bench`'s robot_control_steps_per_second")
    return 0


def _status(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..campaigns import directory as campaign_dir
    from ..campaigns.view import states, summary, table, work_done

    directory = Path(args.directory)
    doc = campaign_dir.read(directory)
    infos = states(directory, doc)
    console = Console()
    console.print(table(directory, doc, infos))
    counts = summary(infos)
    done, total = work_done(doc, infos)
    print(", ".join(f"{n} {k}" for k, n in counts.items()) +
          f"; {done / max(total, 1):.1%} of {total:.3g} robot-control-steps")
    return 0
