"""The controller drawn on its body: nodes inside their voxels, edges between them.

The layout is shared by ``somite draw`` (the body at rest, matplotlib) and the ``--brain``
overlay of ``somite show`` (the deformed body, Pillow): each node gets a place in its voxel's
unit square, and a voxel's square is mapped onto its quadrilateral bilinearly, so a node stays
inside its voxel however the voxel deforms.

Inside a voxel, sensors sit in rows along the bottom in slot order, the actuator near the top
centre and hidden nodes in between at a pseudo-random place seeded by their id, so that a node
keeps its place from one generation, drawing or frame to the next.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..brain.genome import Genome, body_table
from ..errors import bad
from ..sim.partition import Partition
from .camera import View
from .frame import Overlay
from .output import atomic_output, check_output
from .recording import Recording

SENSOR_ROWS = (0.13, 0.29)
SENSORS_PER_ROW = 4
ACTUATOR_AT = (0.5, 0.84)
HIDDEN_BOX = (0.14, 0.86, 0.42, 0.7)  # u_min, u_max, v_min, v_max

POSITIVE = "#1f4fbf"
NEGATIVE = "#d81b60"
CUT = "#ff9800"
MAX_WEIGHT = 3.0
"""|w| at which an edge reaches its full width; initial weights lie in [-1, 1]."""

NODE_STYLE = {
    # kind: (matplotlib marker, fill, edge colour); shapes and fills both differ.
    "sensor": ("o", "#ffffff", "#202020"),
    "hidden": ("s", "#9e9e9e", "#202020"),
    "actuator": ("D", "#202020", "#202020"),
}
MODULE_COLOURS = (
    "#a6cee3", "#b2df8a", "#fdbf6f", "#cab2d6", "#fb9a99", "#ffff99", "#8dd3c7", "#d9d9d9",
)
BRAIN_FORMATS = (".png", ".svg")


class DrawnNode(NamedTuple):
    """A node as drawn: id, kind, voxel (x, y), position (drawing units) and module (or None)."""

    id: int
    kind: str
    voxel: tuple[int, int]
    xy: tuple[float, float]
    module: str | None


class DrawnEdge(NamedTuple):
    """An edge as drawn: a straight segment from ``start`` to ``end`` (drawing units).

    ``cut`` is True when a partition is given and the two nodes lie in different modules.
    """

    src: int
    dst: int
    start: tuple[float, float]
    end: tuple[float, float]
    weight: float
    cut: bool


class BrainDrawing(NamedTuple):
    """Everything a brain picture shows, as data (testable without looking at pixels)."""

    nodes: list[DrawnNode]
    edges: list[DrawnEdge]
    quads: np.ndarray  # (V, 4, 2) voxel corners SW, SE, NE, NW, in drawing units
    labels: tuple[str, ...] | None  # module of each voxel, or None without a partition


def local_layout(genome: Genome) -> np.ndarray:
    """Each node's place (u, v) in its voxel's unit square, u to the right and v up.

    Returns
    -------
    numpy.ndarray
        (N, 2) in the order of ``genome.nodes``; every entry lies strictly inside (0, 1).
    """
    n_slots = body_table(genome.body).n_slots
    index = genome.index
    out = np.empty((genome.n_nodes, 2))
    for i, node in enumerate(genome.nodes):
        if node.kind == "sensor":
            out[i] = _sensor_place(node.slot, n_slots[index.voxel[i]])
        elif node.kind == "actuator":
            out[i] = ACTUATOR_AT
        else:
            # Seeded by the id alone: the node keeps its place whatever else changes.
            u, v = np.random.default_rng(node.id).random(2)
            u_min, u_max, v_min, v_max = HIDDEN_BOX
            out[i] = (u_min + u * (u_max - u_min), v_min + v * (v_max - v_min))
    return out


def _sensor_place(slot: int, n_slots: int) -> tuple[float, float]:
    row = slot // SENSORS_PER_ROW
    in_row = min(SENSORS_PER_ROW, n_slots - row * SENSORS_PER_ROW)
    u = (slot % SENSORS_PER_ROW + 1) / (in_row + 1)
    return u, SENSOR_ROWS[min(row, len(SENSOR_ROWS) - 1)]


def bilinear(quads: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Map points (u, v) of the unit square onto quadrilaterals SW, SE, NE, NW.

    Parameters
    ----------
    quads : numpy.ndarray
        (N, 4, 2) one quadrilateral per point.
    uv : numpy.ndarray
        (N, 2) coordinates in the unit square.

    Returns
    -------
    numpy.ndarray
        (N, 2) the mapped points.
    """
    u = uv[:, 0:1]
    v = uv[:, 1:2]
    sw, se, ne, nw = quads[:, 0], quads[:, 1], quads[:, 2], quads[:, 3]
    return (1 - u) * (1 - v) * sw + u * (1 - v) * se + u * v * ne + (1 - u) * v * nw


def rest_quads(genome: Genome) -> np.ndarray:
    """(V, 4, 2) the voxels at rest in voxel units: voxel (x, y) is [x, x+1] x [y, y+1]."""
    xy = np.asarray(genome.body.shape.voxels, dtype=np.float64).reshape(-1, 1, 2)
    return xy + np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)


def brain_drawing(
    genome: Genome,
    partition: Partition | None = None,
    quads: np.ndarray | None = None,
    layout: np.ndarray | None = None,
) -> BrainDrawing:
    """Lay out ``genome`` on its voxels.

    Parameters
    ----------
    genome : Genome
        The controller.
    partition : Partition, optional
        Modules of the body; must be of the genome's shape.
    quads : numpy.ndarray, optional
        (V, 4, 2) voxel corners in the body's voxel order; the body at rest by default.
    layout : numpy.ndarray, optional
        (N, 2) from :func:`local_layout`, to avoid recomputing it frame after frame.

    Returns
    -------
    BrainDrawing
    """
    labels = _labels(genome, partition)
    quads = rest_quads(genome) if quads is None else np.asarray(quads, dtype=np.float64)
    layout = local_layout(genome) if layout is None else layout
    index = genome.index
    xy = bilinear(quads[index.voxel], layout)
    module = [labels[v] if labels else None for v in index.voxel]
    nodes = [
        DrawnNode(n.id, n.kind, (n.x, n.y), (float(xy[i, 0]), float(xy[i, 1])), module[i])
        for i, n in enumerate(genome.nodes)
    ]
    edges = [
        DrawnEdge(
            e.src,
            e.dst,
            nodes[u].xy,
            nodes[v].xy,
            float(e.weight),
            labels is not None and module[u] != module[v],
        )
        for e, u, v in zip(genome.edges, index.src, index.dst)
    ]
    return BrainDrawing(nodes, edges, quads, labels)


def _labels(genome: Genome, partition: Partition | None) -> tuple[str, ...] | None:
    if partition is None:
        return None
    grid = genome.body.shape.grid_string()
    if partition.shape.grid_string() != grid:
        raise bad(
            "partition",
            partition.grid_string(),
            f"is for shape {partition.shape.grid_string()}, the genome's body is {grid}",
        )
    return partition.labels


def edge_width(weight: float, thinnest: float, thickest: float) -> float:
    """Line width growing linearly with |weight| up to :data:`MAX_WEIGHT`."""
    share = min(abs(weight), MAX_WEIGHT) / MAX_WEIGHT
    return thinnest + (thickest - thinnest) * share


def edge_colour(weight: float) -> str:
    """Blue for a positive (or zero) weight, magenta for a negative one."""
    return POSITIVE if weight >= 0 else NEGATIVE


def draw_brain(
    genome: Genome,
    out_path: str | os.PathLike,
    partition: Partition | None = None,
    voxel_inches: float = 1.3,
    dpi: int = 110,
) -> BrainDrawing:
    """Draw ``genome`` on its body at rest into a PNG or SVG file (written atomically).

    Parameters
    ----------
    genome : Genome
        The controller to draw.
    out_path : path
        ``.png`` or ``.svg``.
    partition : Partition, optional
        Colours voxels by module and highlights the cut edges (nodes in different modules).
    voxel_inches, dpi : float, int
        Size of one voxel on the page, and the PNG resolution.

    Returns
    -------
    BrainDrawing
        What was drawn.
    """
    out_path = check_output(out_path, BRAIN_FORMATS)
    drawing = brain_drawing(genome, partition)
    figure = _figure(genome, drawing, voxel_inches)
    save_figure(figure, out_path, dpi)
    return drawing


def _figure(genome: Genome, drawing: BrainDrawing, voxel_inches: float):
    # The object-oriented API without pyplot: no global figure registry, no GUI backend.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    shape = genome.body.shape
    figure = Figure(figsize=(shape.width * voxel_inches, shape.height * voxel_inches))
    FigureCanvasAgg(figure)
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.set_aspect("equal")
    axes.set_axis_off()
    axes.set_xlim(-0.08, shape.width + 0.08)
    axes.set_ylim(-0.08, shape.height + 0.08)
    _draw_voxels(axes, drawing)
    _draw_edges(axes, drawing)
    _draw_nodes(axes, drawing)
    _title_and_legend(axes, genome, drawing)
    return figure


def _draw_voxels(axes, drawing: BrainDrawing) -> None:
    from matplotlib.patches import Polygon

    modules = list(dict.fromkeys(drawing.labels)) if drawing.labels else []
    for v, quad in enumerate(drawing.quads):
        fill = "#f4f1e8"
        if drawing.labels:
            fill = MODULE_COLOURS[modules.index(drawing.labels[v]) % len(MODULE_COLOURS)]
        axes.add_patch(Polygon(quad, closed=True, facecolor=fill, edgecolor="#555555", lw=1.0))


def _draw_edges(axes, drawing: BrainDrawing) -> None:
    from matplotlib.patches import FancyArrowPatch

    for edge in drawing.edges:
        width = edge_width(edge.weight, 0.4, 3.0)
        # A slight bend tells u -> v from v -> u; a long edge bends less in relative terms.
        style = "arc3,rad=0.12"
        if edge.cut:
            axes.add_patch(FancyArrowPatch(
                edge.start, edge.end, arrowstyle="-", connectionstyle=style,
                color=CUT, lw=width + 4.0, alpha=0.75, shrinkA=0, shrinkB=0, zorder=2,
            ))
        axes.add_patch(FancyArrowPatch(
            edge.start, edge.end, arrowstyle="-|>", mutation_scale=7 + 2 * width,
            connectionstyle=style, color=edge_colour(edge.weight), lw=width, alpha=0.85,
            shrinkA=4, shrinkB=5, zorder=3,
        ))


def _draw_nodes(axes, drawing: BrainDrawing) -> None:
    for kind, (marker, fill, edge) in NODE_STYLE.items():
        points = np.array([n.xy for n in drawing.nodes if n.kind == kind]).reshape(-1, 2)
        axes.scatter(points[:, 0], points[:, 1], s=30, marker=marker, facecolor=fill,
                     edgecolor=edge, linewidths=0.8, zorder=4, label=kind)


def _title_and_legend(axes, genome: Genome, drawing: BrainDrawing) -> None:
    from matplotlib.lines import Line2D

    n_cut = sum(e.cut for e in drawing.edges)
    title = f"{genome.body.shape.grid_string()}: {genome.n_nodes} nodes, {genome.n_edges} edges"
    if drawing.labels:
        title += f", {n_cut} cut by the partition"
    axes.set_title(title, fontsize=9)
    handles = [
        Line2D([], [], ls="", marker=m, markerfacecolor=f, markeredgecolor=e, label=k)
        for k, (m, f, e) in NODE_STYLE.items()
    ] + [
        Line2D([], [], color=POSITIVE, lw=1.5, label="w > 0"),
        Line2D([], [], color=NEGATIVE, lw=1.5, label="w < 0"),
    ]
    if drawing.labels:
        handles.append(Line2D([], [], color=CUT, lw=5, alpha=0.75, label="cut edge"))
    axes.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.01),
                ncol=len(handles), fontsize=7, frameon=False, handlelength=1.5,
                columnspacing=1.0)


def save_figure(figure, out_path: str | os.PathLike, dpi: int) -> Path:
    """Save a matplotlib figure atomically (temp file in the same folder, then rename)."""
    out_path = Path(out_path)
    with atomic_output(out_path) as tmp:
        # "tight" trims the margins left by the equal aspect ratio of the body.
        figure.savefig(tmp, dpi=dpi, format=out_path.suffix.lower().lstrip("."),
                       bbox_inches="tight", pad_inches=0.05)
    return out_path


# -- the overlay of ``somite show --brain`` -----------------------------------------------------


def brain_overlay(genome: Genome) -> Overlay:
    """An overlay for :func:`somite.viz.frame.render_frame` drawing ``genome`` on the deformed
    body: edges (white halo, colour by sign, width by |weight|), then nodes (sensor: white
    circle, hidden: grey square, actuator: black diamond)."""
    layout = local_layout(genome)

    def paint(draw, view: View, recording: Recording, step: int) -> None:
        if recording.body != genome.body:
            raise bad("genome", genome.body.shape.grid_string(), "is not the recorded body")
        drawing = brain_drawing(genome, quads=recording.quads(step), layout=layout)
        px = view.pixel
        for edge in drawing.edges:
            ends = [tuple(p) for p in view.to_pixels(np.array([edge.start, edge.end])).tolist()]
            width = max(1, int(round(edge_width(edge.weight, 0.7, 3.0) * px)))
            draw.line(ends, fill=(255, 255, 255), width=width + int(round(2 * px)))
            draw.line(ends, fill=edge_colour(edge.weight), width=width)
        radius = max(1.5, 0.045 * 3.0 * view.scale / px) * px
        centres = view.to_pixels(np.array([n.xy for n in drawing.nodes]).reshape(-1, 2))
        for node, (cx, cy) in zip(drawing.nodes, centres.tolist()):
            _paint_node(draw, node.kind, cx, cy, radius, px)

    return paint


def _paint_node(draw, kind: str, cx: float, cy: float, r: float, px: float) -> None:
    _, fill, edge = NODE_STYLE[kind]
    width = max(1, int(round(px)))
    if kind == "sensor":
        draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=fill, outline=edge, width=width)
    elif kind == "hidden":
        draw.rectangle((cx - r, cy - r, cx + r, cy + r), fill=fill, outline=edge, width=width)
    else:
        r *= 1.3
        draw.polygon([(cx, cy - r), (cx + r, cy), (cx, cy + r), (cx - r, cy)], fill=fill,
                     outline=edge, width=width)


__all__ = [
    "BrainDrawing",
    "DrawnEdge",
    "DrawnNode",
    "bilinear",
    "brain_drawing",
    "brain_overlay",
    "draw_brain",
    "edge_colour",
    "edge_width",
    "local_layout",
    "rest_quads",
    "save_figure",
]
