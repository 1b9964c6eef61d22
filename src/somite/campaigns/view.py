"""What a campaign's progress looks like: the live view of ``campaign run`` and the table of
``campaign status``, both read from the disk (the truth, whoever runs the tasks)."""

from __future__ import annotations

import time
from pathlib import Path

from .directory import state
from .tasks import estimate


def states(directory: Path, doc: dict) -> list[dict]:
    return [state(directory, t) for t in doc["tasks"]]


def work_done(doc: dict, infos: list[dict]) -> tuple[float, float]:
    """(robot-control-steps done, in all), from the tasks' estimates: a running run counts
    the fraction of its generations it has logged."""
    done = total = 0.0
    for task, info in zip(doc["tasks"], infos):
        steps = estimate(task)
        total += steps
        if info["state"] == "done":
            done += steps
        elif info["generation"] is not None and info["generations"]:
            done += steps * min(1.0, info["generation"] / info["generations"])
    return done, total


def _duration(seconds: float) -> str:
    seconds = int(seconds)
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def _fmt(value) -> str:
    return "-" if value is None else f"{value:.3f}"


def table(directory: Path, doc: dict, infos: list[dict] | None = None):
    """The rich Table of every task: id, kind, state, generation/total, best v_x."""
    from rich.table import Table

    infos = states(directory, doc) if infos is None else infos
    grid = Table(title=f"campaign {doc.get('name')} in {directory}")
    for name in ("task", "kind", "state", "generation", "best v_x [m/s]"):
        grid.add_column(name, justify="right" if name.startswith(("gen", "best")) else "left",
                        no_wrap=name == "task")
    for info in infos:
        generation = "-"
        if info["generations"] is not None:
            reached = "-" if info["generation"] is None else info["generation"]
            generation = f"{reached}/{info['generations']}"
        grid.add_row(info["id"], info["kind"], info["state"], generation, _fmt(info["best"]))
    return grid


def summary(infos: list[dict]) -> dict[str, int]:
    counts = {"done": 0, "running": 0, "partial": 0, "queued": 0}
    for info in infos:
        counts[info["state"]] += 1
    return counts


class LiveView:
    """The progress of a running campaign: runs done / running / queued, generations, ETA,
    the running runs, the Dask dashboard's address. Nothing at all when ``quiet``."""

    def __init__(self, directory: Path, doc: dict, quiet: bool) -> None:
        self.directory, self.doc, self.quiet = directory, doc, quiet
        self.live = None
        self.started = time.monotonic()
        self.at_start = None
        self.last = 0.0
        self.dashboard = ""

    def __enter__(self) -> LiveView:
        if not self.quiet:
            from rich.live import Live

            self.live = Live(self._render(""), refresh_per_second=2, transient=False)
            self.live.start()
        return self

    def update(self, outcome) -> None:
        if self.live is None or time.monotonic() - self.last < 1.0:
            return
        self.last = time.monotonic()
        self.dashboard = outcome.dashboard
        self.live.update(self._render(self.dashboard))

    def _render(self, dashboard: str):
        from rich.console import Group
        from rich.text import Text

        infos = states(self.directory, self.doc)
        counts = summary(infos)
        done, total = work_done(self.doc, infos)
        if self.at_start is None:
            self.at_start = done
        elapsed = time.monotonic() - self.started
        rate = (done - self.at_start) / elapsed if elapsed > 0 else 0.0
        eta = _duration((total - done) / rate) if rate > 0 else "-"
        runs = [i for i in infos if i["generations"] is not None]
        reached = sum(min(i["generation"] or 0, i["generations"]) if i["state"] != "done"
                      else i["generations"] for i in runs)
        lines = [
            Text(f"campaign {self.doc.get('name')} -> {self.directory}", style="bold"),
            Text(f"tasks: {counts['done']} done, {counts['running']} running, "
                 f"{counts['queued'] + counts['partial']} queued (of {len(infos)})   "
                 f"generations {reached}/{sum(i['generations'] for i in runs)}   "
                 f"{done / max(total, 1):.1%} of {total:.3g} robot-control-steps   "
                 f"elapsed {_duration(elapsed)}  ETA {eta}"),
            Text("dashboard: " + (dashboard or "none (Dask's needs bokeh: pip install 'somite[dashboard]')")),
        ]
        for info in infos:
            if info["state"] == "running":
                generation = "" if info["generation"] is None else (
                    f"  generation {info['generation']}/{info['generations']}"
                    f"  best v_x {_fmt(info['best'])}")
                lines.append(Text(f"  {info['id']}{generation}"))
        return Group(*lines)

    def __exit__(self, *exc) -> None:
        if self.live is not None:
            self.live.update(self._render(self.dashboard))
            self.live.stop()
            if not self.live.console.is_terminal:
                self.live.console.line()
