"""A replay page: one self-contained HTML file that replays recorded episodes in a browser.

``somite show RUN --out walk.html`` writes it: no server, no network, nothing beside it. The
page holds each episode's recording, packed compactly (corner positions as int16 offsets from
the centre of mass, actuation and readings as bytes, contacts as bits, all base64), and the
drawing code (``replay.js``, inlined), which paints on a canvas what :mod:`somite.viz.frame`
paints into a video frame: the terrain, the voxels coloured by area ratio, the sensor half
discs and lidar rays, the time and v_x. A panel beside each robot shows its controller's graph
(:mod:`somite.viz.brain`'s layout) with every node coloured by its activity at the step shown.

Several episodes on one page play on one clock, each in its own view or, as ghosts, over the
first one's. A 30 s worm episode makes a page of 0.84 MB.

The page keeps a small test hook: ``#t=SECONDS`` in its address shows that time, and ``#probe``
writes the state shown (step, time, x, v_x, corner positions) into ``data-probe`` of ``<body>``,
so that a headless browser's ``--dump-dom`` can read it back; errors are written into
``data-errors`` of ``<html>``.

See docs/decisions.md, "Watching robots".
"""

from __future__ import annotations

import base64
import html
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..brain.delays import edge_delays
from ..brain.genome import Genome, body_table
from ..brain.kinds import ACTUATOR, HIDDEN, SENSOR
from ..errors import bad
from ..sim.config import CONTROL_HZ, VOXEL_SIDE
from .brain import brain_drawing, edge_colour
from .frame import (
    AREA_RAMP,
    GRID,
    GRID_STEP,
    GROUND,
    GROUND_EDGE,
    OUTLINE,
    RAY,
    SECTOR_RADIUS,
    SENSOR_COLOURS,
    SKY,
    TEXT,
    check_speed,
)
from .output import atomic_output, check_output
from .recording import CAMERA_WINDOW, VELOCITY_WINDOW, Recording

REPLAY_FORMATS = (".html",)
TERRAIN_MARGIN = 60.0
"""Metres of terrain kept beyond the farthest the robot went either way (the view is ~40 m)."""


@dataclass(frozen=True)
class ReplayRun:
    """One episode on a replay page: its recording, its controller (for the graph panel and
    the node activity; None for an open-loop controller), a name and a gait line."""

    recording: Recording
    genome: Genome | None = None
    name: str = ""
    gait: str = ""


def node_activity(genome: Genome, recording: Recording) -> np.ndarray:
    """(T, N) every node's value at each recorded step, replayed from the recorded readings.

    The controller's synchronous step (:mod:`somite.brain.kernels`): h_0 = 0; at step k >= 1 a
    sensor reads tanh(reading_k), every other node act(sum of h_{k-D}(src) * w + b), D the
    edge's delay (1, or its length's with ``delay_per_voxel``, :mod:`somite.brain.delays`); the
    actuators' values are the recorded actuation (tests check it).
    """
    index = genome.index
    kind = np.asarray(index.kind)
    n_steps, n_nodes = len(recording.readings), genome.n_nodes
    src = np.asarray(index.src, dtype=np.int64)
    dst = np.asarray(index.dst, dtype=np.int64)
    weight = np.array([e.weight for e in genome.edges], dtype=np.float64)
    bias = np.array([e.bias for e in genome.edges], dtype=np.float64)
    sensor = np.flatnonzero(kind == SENSOR)
    hidden = kind == HIDDEN
    table = body_table(genome.body)
    reading = (np.asarray(table.first_reading)[np.asarray(index.voxel)] + np.asarray(index.slot)
               )[sensor]
    sigmoid = recording.config.hidden_activation == "sigmoid"
    # Each edge reads its source as it was its delay ago (1 step but with delay_per_voxel).
    lag = edge_delays(genome)
    h = np.zeros((n_steps, n_nodes))
    for k in range(1, n_steps):
        total = np.zeros(n_nodes)
        np.add.at(total, dst, h[np.maximum(k - lag, 0), src] * weight + bias)
        value = np.tanh(total)
        if sigmoid:
            value[hidden] = 1.0 / (1.0 + np.exp(-total[hidden]))
        value[sensor] = np.tanh(recording.readings[k, reading])
        h[k] = value
    return h


def _b64(array: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def _hex(colour) -> str:
    if isinstance(colour, str):
        return colour
    return "#" + "".join(f"{int(round(c)):02x}" for c in colour)


def run_payload(run: ReplayRun) -> dict:
    """The page's data of one episode (what ``replay.js`` decodes)."""
    rec = run.recording
    n = len(rec.pos)
    com = rec.com.astype(np.float64)
    offsets = rec.pos - com[:, None, :]
    reach = float(np.max(np.abs(offsets))) if offsets.size else 0.0
    pos_scale = max(reach, 1e-6) / 32000.0  # int16 with a little headroom
    quantised = np.round(offsets / pos_scale).astype("<i2")
    x_lo = float(np.min(rec.pos[..., 0])) - TERRAIN_MARGIN
    x_hi = float(np.max(rec.pos[..., 0])) + TERRAIN_MARGIN
    xs, ys = rec.terrain.xs, rec.terrain.ys
    lo = max(0, int(np.searchsorted(xs, x_lo)) - 1)
    hi = min(len(xs), int(np.searchsorted(xs, x_hi)) + 1)
    shape = rec.body.shape
    payload = {
        "name": run.name,
        "shape": shape.grid_string(),
        "width": shape.width,
        "height": shape.height,
        "terrain": rec.terrain.name,
        "velocity": None if not np.isfinite(rec.velocity) else float(rec.velocity),
        "complete": bool(rec.complete),
        "gait": run.gait,
        "steps": n,
        "points": int(rec.pos.shape[1]),
        "voxels": int(shape.n_voxels),
        "corners": rec.corners.astype(int).tolist(),
        "com": _b64(com.astype("<f8")),
        "camera": _b64(rec.camera.astype("<f8")),
        "pos": _b64(quantised),
        "posScale": pos_scale,
        "act": _b64(np.round(np.clip(rec.actuation, -1, 1) * 127).astype("i1")),
        "readingCount": int(rec.readings.shape[1]),
        "readings": _b64(np.round(np.clip(rec.readings, 0, 1) * 255).astype("u1")),
        "contact": _b64(np.packbits(rec.contact.astype(bool), axis=None)),
        "sensors": [[[kind, list(idx)] for kind, idx in voxel] for voxel in rec.sensor_groups],
        "groundX": _b64(xs[lo:hi].astype("<f8")),
        "groundY": _b64(ys[lo:hi].astype("<f4")),
        "areaDelta": rec.config.area_delta,
        "lidar": {"angles": list(map(float, rec.config.lidar_angles)),
                  "range": float(rec.config.lidar_range), "frame": rec.config.lidar_frame},
        "brain": None,
    }
    if run.genome is not None:
        payload["brain"] = brain_payload(run.genome, rec)
    return payload


def brain_payload(genome: Genome, recording: Recording) -> dict:
    """The controller's graph at rest (voxel units) and its nodes' activity, one byte each."""
    drawing = brain_drawing(genome)
    kinds = {SENSOR: "sensor", HIDDEN: "hidden", ACTUATOR: "actuator"}
    index = genome.index
    activity = node_activity(genome, recording)
    return {
        "quads": np.round(drawing.quads, 4).tolist(),
        "nodes": [[kinds[int(k)], round(n.xy[0], 4), round(n.xy[1], 4)]
                  for k, n in zip(index.kind, drawing.nodes)],
        "edges": [[int(u), int(v), round(e.weight, 3), edge_colour(e.weight)]
                  for e, u, v in zip(drawing.edges, index.src, index.dst)],
        "activity": _b64(np.round(np.clip(activity, -1, 1) * 127).astype("i1")),
    }


def page_style() -> dict:
    """The colours and sizes the page shares with the video frames (:mod:`somite.viz.frame`)."""
    return {
        "hz": CONTROL_HZ,
        "voxelSide": VOXEL_SIDE,
        "gridStep": GRID_STEP,
        "sectorRadius": SECTOR_RADIUS,
        "cameraWindow": CAMERA_WINDOW,
        "velocityWindow": VELOCITY_WINDOW,
        "sky": _hex(SKY),
        "grid": _hex(GRID),
        "ground": _hex(GROUND),
        "groundEdge": _hex(GROUND_EDGE),
        "outline": _hex(OUTLINE),
        "ray": _hex(RAY),
        "text": _hex(TEXT),
        "ramp": [_hex(c) for c in AREA_RAMP],
        "sensorColours": {k: _hex(c) for k, c in SENSOR_COLOURS.items()},
    }


def replay_html(runs: Sequence[ReplayRun], title: str = "somite replay",
                speed: float = 1.0) -> str:
    """The page's text; it opens paused at t = 0, set to play at ``speed`` (0.05 .. 4)."""
    if not runs:
        raise bad("runs", 0, "a replay page needs at least one episode")
    data = {"style": page_style(), "speed": check_speed(speed),
            "runs": [run_payload(r) for r in runs]}
    text = _script_safe(json.dumps(data, separators=(",", ":"), allow_nan=False))
    script = resources.files(__package__).joinpath("replay.js").read_text(encoding="utf-8")
    return _TEMPLATE.format(title=html.escape(title), data=text, script=script)


# Inside a <script> element the HTML parser ends the data at "</script" and reads "<!--" as
# the start of an escape that swallows the page's own script: a run's name (a genome's file
# name) holding either left a blank page. As JSON escapes none of these can appear; U+2028/9
# too, which older JavaScript reads as line breaks.
_UNSAFE = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028",
           "\u2029": "\\u2029"}


def _script_safe(text: str) -> str:
    """JSON text ``text`` safe inside a script element, the same JSON once parsed."""
    return text.translate(str.maketrans(_UNSAFE))


def write_replay(runs: Sequence[ReplayRun], out_path: str | os.PathLike,
                 title: str = "somite replay", speed: float = 1.0) -> Path:
    """Write the replay page of ``runs`` to ``out_path`` (.html), all or nothing."""
    out_path = check_output(out_path, REPLAY_FORMATS)
    page = replay_html(runs, title, speed)
    with atomic_output(out_path) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return out_path


# The first script only collects errors (a syntax error in the second one included), so that a
# headless browser reads them from the DOM.
_TEMPLATE = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<script>
window.somiteErrors = [];
(function () {{
  function keep(text) {{
    window.somiteErrors.push(String(text));
    document.documentElement.setAttribute("data-errors", JSON.stringify(window.somiteErrors));
  }}
  window.addEventListener("error", function (e) {{ keep(e.message || e); }});
  window.addEventListener("unhandledrejection", function (e) {{ keep(e.reason); }});
  var original = console.error;
  console.error = function () {{ keep(Array.prototype.join.call(arguments, " ")); 
    original.apply(console, arguments); }};
}})();
</script>
<style>
body {{ font: 14px system-ui, sans-serif; margin: 12px; color: #191919; background: #fafafa; }}
h1 {{ font-size: 17px; margin: 0 0 6px; }}
#controls {{ display: flex; flex-wrap: wrap; gap: 10px; align-items: center; margin: 6px 0; }}
#controls label {{ white-space: nowrap; }}
#scrub {{ flex: 1 1 320px; }}
#speed {{ width: 5em; }}
.run {{ display: flex; flex-wrap: wrap; gap: 8px; margin: 8px 0; align-items: flex-start; }}
.run canvas {{ border: 1px solid #ccc; background: #fff; }}
.meta {{ font-size: 13px; margin: 2px 0; }}
.readout {{ font-family: ui-monospace, monospace; font-size: 13px; }}
.help {{ color: #666; font-size: 12px; }}
</style>
</head>
<body>
<h1>{title}</h1>
<div id="controls">
<button id="play" type="button">play</button>
<input id="scrub" type="range" min="0" max="0" value="0" step="1" aria-label="time">
<label>speed <input id="speed" type="number" min="0.05" max="4" step="0.05" value="1">x</label>
<label><input id="follow" type="checkbox" checked> follow</label>
<label><input id="sensors" type="checkbox" checked> sensors</label>
<label><input id="act" type="checkbox"> actuation</label>
<label id="ghostLabel"><input id="ghosts" type="checkbox"> ghosts</label>
</div>
<div class="help">space: play/pause; &larr; &rarr;: one step (shift: one second); home/end;
[ ]: slower/faster</div>
<div id="runs"></div>
<script id="somite-data" type="application/json">{data}</script>
<script>
{script}
</script>
</body>
</html>
"""


__all__ = [
    "REPLAY_FORMATS",
    "ReplayRun",
    "node_activity",
    "replay_html",
    "run_payload",
    "write_replay",
]
