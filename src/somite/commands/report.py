"""``somite report``: a campaign directory's Markdown report, figures and numbers."""

from __future__ import annotations

import argparse

from ..report.markdown import left_empty
from ..report.rerun import FRESH_COUNT
from ._progress import stages
from .common import add_options, warn, whole_int

HELP = ("Report a campaign directory: the paper's Table 1 and Figures 3, 5, 7-12 beside the "
        "paper's numbers, the final bests' edge lengths where the campaign declares them, "
        "validation re-runs, time-lapses (index.md, report.json, figures/).")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign", help="campaign directory (written by somite campaign run)")
    parser.add_argument("--out", required=True, help="report folder")
    add_options(parser, "validation", notes={
        "validation": "every final best is re-run on them (cached in the report folder)"})
    parser.add_argument("--fresh", type=whole_int("fresh"), default=FRESH_COUNT, metavar="N",
                        help="also re-run every final best on N fresh terrains (neither "
                        "training nor validation ones) under fresh sensor noise (cached in the "
                        f"report folder; 0: none) (default {FRESH_COUNT})")
    parser.add_argument("--no-timelapse", action="store_true",
                        help="draw no time-lapse strips")
    parser.add_argument("--under-way", action="store_true",
                        help="an interim report: also draw the evolve runs not finished yet in "
                        "the curves (Figures 3 and 10, the cuts during evolution), to their last "
                        "logged generation, and a time-lapse of each one's best so far")
    add_options(parser, "quiet")


def run(args: argparse.Namespace) -> int:
    from ..report.build import build_report

    with stages(args.quiet) as stage:
        report = build_report(args.campaign, args.out, args.validation,
                              timelapse=not args.no_timelapse, stage=stage,
                              under_way=args.under_way, fresh=args.fresh)
    if not args.quiet:
        status = report["status"]["experiments"]
        done = sum(s["done"] for s in status.values())
        total = sum(s["tasks"] for s in status.values())
        cache = report["cache"]
        print(f"wrote {args.out}/index.md and report.json: {done} of {total} tasks finished; "
              f"{cache['genomes_simulated']} bests re-run on the validation or fresh terrains, "
              f"{cache['strips_drawn']} time-lapses drawn (the rest from the cache)")
        missing = left_empty(report["figures"]["missing"])
        if missing:
            print("left empty, as no experiment feeds them (an experiment's `figures` table "
                  "declares them): " + "; ".join(f"{k} ({why})" for k, why in missing.items()))
    # The banner of index.md, also with --quiet: a caveat on the result, not progress.
    for text in report["caveats"]["banner"]:
        warn(args.prog, text)
    return 0
