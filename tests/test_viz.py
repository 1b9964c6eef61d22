"""Rendering, brain drawings, run plots and their statistics (issue 4).

Episodes are short (1-2 s) and images small, so that the whole file runs in seconds once the
simulator's Numba kernel is cached.
"""

import ast
import gc
import itertools
import json
import warnings
from math import comb
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from PIL import Image
from scipy.stats import mannwhitneyu

from somite.analysis.stats import LOG_COLUMNS, load_run, mann_whitney
from somite.brain.controllers import Sine, Table
from somite.brain.genome import Edge, Genome, body_table
from somite.cli import main
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.sim.body import Body
from somite.sim.config import VOXEL_SIDE, preset
from somite.sim.partition import Partition
from somite.viz.brain import bilinear, brain_drawing, draw_brain
from somite.viz.frame import GRID, SKY, area_colour, frame_steps, render_frame
from somite.viz.plots import curve, plot_runs, plot_validation, stats_path
from somite.viz.recording import lidar_segments
from somite.viz.strip import render_strip
from somite.viz.video import record_episode, render_episode, write_video

SRC = Path(__file__).resolve().parents[1] / "src" / "somite"
WORM = Body.build("worm")
BIPED = Body.build("biped")
# A point of a voxel that no sensor disc (upper half, at the centre) and no lidar ray (they
# leave the centre towards +x) covers: the voxel's own colour shows there.
CLEAR_SPOT = (0.3, 0.2)


def read_video(path):
    """Every frame of a video file, through imageio (T, H, W, 3)."""
    with warnings.catch_warnings():
        # imageio-ffmpeg's reader leaves its pipes to the garbage collector (ResourceWarning).
        warnings.simplefilter("ignore", ResourceWarning)
        frames = iio.imread(path, index=None)
        gc.collect()
    return frames


def short(duration, **options):
    return preset("paper", duration=duration, **options)


@pytest.fixture(scope="module")
def sine_worm():
    return record_episode(WORM, Sine(), "hilly-1-10-0", short(2.0), seed=0)


# -- videos -------------------------------------------------------------------------------------


def test_frame_steps_show_every_other_step_at_30_fps():
    assert frame_steps(120, 30).tolist() == list(range(0, 120, 2))
    assert frame_steps(120, 60).tolist() == list(range(120))
    with pytest.raises(SomiteError, match="fps"):
        frame_steps(120, 0)


def test_mp4_has_duration_times_fps_frames_and_they_change(tmp_path):
    genome = initial_genome(WORM, np.random.default_rng(0))
    out = render_episode(genome, tmp_path / "walk.mp4", "flat", duration=2.0, fps=30,
                         width=192, height=108)
    frames = read_video(out)
    assert frames.shape == (60, 108, 192, 3)
    change = np.abs(np.diff(frames.astype(int), axis=0)).mean(axis=(1, 2, 3))
    assert (change > 0).all()  # at least the clock moves in every frame
    assert np.abs(frames[-1].astype(int) - frames[0].astype(int)).mean() > 1.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.mp4"]


def test_gif_frame_count_follows_fps(tmp_path, sine_worm):
    genome = initial_genome(WORM, np.random.default_rng(1))
    out = render_episode(genome, tmp_path / "walk.gif", "flat", duration=1.5, fps=20,
                         width=96, height=64, brain=True)
    frames = iio.imread(out, index=None)
    assert frames.shape[:3] == (30, 64, 96)
    assert len({frame.tobytes() for frame in frames}) == 30


def test_unfinished_video_leaves_no_file(tmp_path, sine_worm):
    def images():
        yield render_frame(sine_worm, 0, 64, 48).image
        raise RuntimeError("renderer crashed")

    with pytest.raises(RuntimeError):
        write_video(images(), tmp_path / "broken.mp4", 30)
    assert list(tmp_path.iterdir()) == []


# -- frames: pixels where the simulation says ---------------------------------------------------


def colours_at(image, view, quads, uv):
    """The image's colour (V, 3) at point ``uv`` of each voxel's unit square, through ``view``."""
    spots = bilinear(quads, np.tile(uv, (len(quads), 1)))
    pixels = np.floor(view.to_pixels(spots)).astype(int)
    rgb = np.asarray(image)
    assert ((pixels >= 0) & (pixels < (rgb.shape[1], rgb.shape[0]))).all(), "robot off-frame"
    return rgb[pixels[:, 1], pixels[:, 0]].astype(int)


def assert_robot_where_simulated(image, view, recording, step):
    """Inside every voxel (near its bottom or top side) its area colour; just outside the
    robot's bottom and top sides, something else."""
    quads = recording.quads(step)
    colours = area_colour(recording.area_ratio(step), recording.config.area_delta).astype(int)
    rows = np.array([y for _, y in recording.body.shape.voxels])
    bottom, top = rows == 0, rows == rows.max()
    for uv, where in ((CLEAR_SPOT, slice(None)), ((0.3, 0.85), slice(None))):
        seen = colours_at(image, view, quads, uv)[where]
        assert (np.abs(seen - colours[where]).max(axis=1) <= 2).all()
    for uv, where in (((0.3, -0.15), bottom), ((0.3, 1.15), top)):
        seen = colours_at(image, view, quads, uv)[where]
        assert (np.abs(seen - colours[where]).max(axis=1) > 40).all()


@pytest.mark.parametrize("step", [30, 100])
def test_voxels_are_drawn_where_the_simulation_puts_them(sine_worm, step):
    frame = render_frame(sine_worm, step, 640, 360)
    # The camera follows: the smoothed centre of mass sits mid-width, 38 % up from the bottom.
    centre = frame.view.to_pixels(sine_worm.camera[step])
    assert centre == pytest.approx((320.0, 360 * (1 - 0.38)))
    assert frame.view.to_world(centre) == pytest.approx(sine_worm.camera[step])
    assert_robot_where_simulated(frame.image, frame.view, sine_worm, step)
    # Two voxel sides above the centre of mass there is sky, not robot.
    above = sine_worm.com[step] + (0.0, 2 * VOXEL_SIDE + 1.0)
    column, row = np.floor(frame.view.to_pixels(above)).astype(int)
    sky = np.asarray(frame.image)[row, column].astype(int)
    # Sky, or sky blended with a faint vertical grid line; far from every voxel colour.
    assert np.abs(sky - SKY).max() <= np.abs(np.subtract(GRID, SKY)).max()


def test_strip_tiles_map_the_world_into_the_strip(sine_worm):
    strip = render_strip(sine_worm, 3, 400, 240)
    assert strip.image.size == (3 * 400 + 2 * 4, 240)
    assert [f.step for f in strip.frames] == [0, 60, 120]
    for frame in strip.frames:
        assert_robot_where_simulated(strip.image, frame.view, sine_worm, frame.step)


@pytest.mark.parametrize("preset_name", ["paper", "original-code"])  # world / voxel frame
def test_lidar_rays_end_on_the_ground_they_measured(preset_name):
    # A tumbling biped, so that voxel-frame rays differ from world-frame ones.
    recording = record_episode(BIPED, Sine(), "hilly-1-10-0", preset(preset_name, duration=2.0))
    misses = []
    for step in range(10, recording.n_steps + 1, 10):
        for start, end in lidar_segments(recording, step):
            if np.linalg.norm(end - start) < 0.9 * recording.config.lidar_range:
                misses.append(abs(end[1] - recording.terrain.height_at(end[0])))
    assert len(misses) > 10
    # Readings carry noise of 0.01 x 10 m and the rays are drawn from the step's positions.
    assert max(misses) < 0.35


@pytest.mark.parametrize("actuation, hue", [(1.0, "red"), (-1.0, "green")])
def test_colour_follows_the_area_ratio(actuation, hue):
    controller = Table(np.full((1, WORM.shape.n_voxels), actuation))
    recording = record_episode(WORM, controller, "flat", short(1.5), seed=0)
    step = recording.n_steps
    ratio = recording.area_ratio(step)
    assert (ratio < 0.9).all() if hue == "red" else (ratio > 1.1).all()
    frame = render_frame(recording, step, 320, 180)
    spots = bilinear(recording.quads(step), np.tile(CLEAR_SPOT, (len(ratio), 1)))
    pixels = np.floor(frame.view.to_pixels(spots)).astype(int)
    r, g, b = np.asarray(frame.image)[pixels[:, 1], pixels[:, 0]].astype(int).T
    if hue == "red":
        assert ((r > 180) & (g < 110) & (b < 80)).all()
    else:
        assert ((g > r + 50) & (g > b + 50)).all()


# -- brain drawings ------------------------------------------------------------------------------


def inside(point, voxel):
    (x, y), (px, py) = voxel, point
    return x < px < x + 1 and y < py < y + 1


@pytest.mark.parametrize("body", [WORM, BIPED], ids=["worm", "biped"])
def test_initial_genome_draws_one_edge_per_sensor_inside_each_voxel(body):
    genome = initial_genome(body, np.random.default_rng(0))
    drawing = brain_drawing(genome)
    per_voxel = dict.fromkeys(body.shape.voxels, 0)
    for edge in drawing.edges:
        voxel = next(v for v in body.shape.voxels if inside(edge.start, v))
        # Both ends in one voxel's square: a straight segment then stays inside the voxel.
        assert inside(edge.end, voxel)
        per_voxel[voxel] += 1
    assert list(per_voxel.values()) == list(body_table(body).n_slots)
    kinds = {n.id: n.kind for n in drawing.nodes}
    assert all(kinds[e.src] == "sensor" and kinds[e.dst] == "actuator" for e in drawing.edges)
    assert len({n.xy for n in drawing.nodes}) == genome.n_nodes  # no two nodes on one spot


def test_partition_marks_exactly_the_cut_edges(tmp_path):
    genome = initial_genome(WORM, np.random.default_rng(0))
    partition = Partition.preset("worm-halves", WORM.shape)
    assert not any(e.cut for e in brain_drawing(genome, partition).edges)
    back_sensor = next(n.id for n in genome.nodes if (n.x, n.y, n.kind) == (0, 0, "sensor"))
    front_actuator = next(n.id for n in genome.nodes if (n.x, n.y, n.kind) == (5, 1, "actuator"))
    bridge = Edge(back_sensor, front_actuator, -2.0, 0.1)
    bridged = Genome(WORM, genome.nodes, genome.edges + (bridge,))
    drawing = draw_brain(bridged, tmp_path / "brain.svg", partition)
    assert [(e.src, e.dst) for e in drawing.edges if e.cut] == [(back_sensor, front_actuator)]
    assert (tmp_path / "brain.svg").read_text().lstrip().startswith("<?xml")


# -- plots and statistics ------------------------------------------------------------------------


def fake_run(root, name, config, final_velocity, n_generations=4, drop_log=False):
    """A run directory as ``somite evolve`` writes it, ending at ``final_velocity``."""
    path = root / name
    path.mkdir()
    (path / "config.json").write_text(json.dumps(config))
    if drop_log:
        return path
    rows = [",".join(LOG_COLUMNS)]
    for g in range(n_generations):
        v = final_velocity * (g + 1) / n_generations
        size = 50 + 3 * g
        rows.append(f"{g},{96 * (g + 1)},{0.5 * g},{v},{v / 2},{v / 4},{size // 2},"
                    f"{size - size // 2},{size},{size - 4},add_edge,0,0,{v / 3 if g % 2 else ''}")
    (path / "log.csv").write_text("\n".join(rows) + "\n")
    return path


def exact_two_sided_p(a, b):
    """The exact Mann-Whitney p-value by listing every way to split the pooled sample in two:
    the share of splits whose U lies at least as far from its mean as the observed one."""
    pooled = np.array(list(a) + list(b), dtype=float)

    def u_of(first):
        chosen = pooled[list(first)]
        rest = np.delete(pooled, list(first))
        return sum((x > y) + 0.5 * (x == y) for x in chosen for y in rest)

    mean = len(a) * len(b) / 2
    observed = abs(u_of(range(len(a))) - mean)
    null = [abs(u_of(first) - mean) for first in itertools.combinations(range(len(pooled)), len(a))]
    return sum(u >= observed - 1e-12 for u in null) / comb(len(pooled), len(a))


def test_mann_whitney_matches_counting_by_hand():
    # U counts the pairs a_i > b_j; with 3 + 3 values there are C(6, 3) = 20 equally likely
    # splits, and U = 0 or 9 happens in 1 each: p = 2 / 20.
    assert mann_whitney([1, 2, 3], [4, 5, 6]) == (0.0, 0.1)
    # U = 1 (only 4 > 3): U <= 1 or U >= 8 in 4 of 20 splits.
    assert mann_whitney([1, 2, 4], [3, 5, 6]) == pytest.approx((1.0, 0.2))
    assert exact_two_sided_p([1, 2, 4], [3, 5, 6]) == pytest.approx(0.2)
    a, b = [0.3, 1.1, 2.5, 0.9], [1.7, 3.0, 2.2, 4.1, 2.8]
    assert mann_whitney(a, b).p == pytest.approx(exact_two_sided_p(a, b))


def test_plot_runs_writes_figure_and_scipy_p_values(tmp_path):
    worm = [1.0, 2.0, 4.0]
    biped = [3.0, 5.0, 6.0]
    runs = [fake_run(tmp_path, f"worm{i}", {"shape": "worm", "seed": i, "omega": 1.0}, v)
            for i, v in enumerate(worm)]
    runs += [fake_run(tmp_path, f"biped{i}", {"shape": "biped", "seed": i, "omega": 1.0}, v)
             for i, v in enumerate(biped)]
    out = plot_runs(runs, tmp_path / "fig.png", group_by="shape")
    with Image.open(out) as image:
        assert image.size[0] > 100
    stats = json.loads(stats_path(out).read_text())
    assert list(stats["groups"]) == ["shape=biped", "shape=worm"]
    assert stats["groups"]["shape=worm"]["final"] == worm
    assert stats["groups"]["shape=biped"]["median"] == 5.0
    [test] = stats["tests"]
    expected = mannwhitneyu(biped, worm, alternative="two-sided")
    assert (test["u"], test["p"]) == (float(expected.statistic), float(expected.pvalue))
    # By hand: 8 of the 9 pairs have the biped ahead; U >= 8 or U <= 1 in 4 of 20 splits.
    assert (test["u"], test["p"]) == pytest.approx((8.0, 0.2))
    svg = plot_runs(runs, tmp_path / "box.svg", group_by="omega,shape", kind="box")
    assert svg.read_text().lstrip().startswith("<?xml")


def test_figure5_bars_name_the_papers_one_sided_test_beside_the_two_sided_one():
    from somite.viz.report_figures import boxes_figure

    # Every graph run ahead of every weights-only run: U = 9, one-sided p = 1/20 (only this
    # split of the 20 is as extreme in that direction), two-sided 2/20.
    panels = {"biped": {"topology + weights": [5.0, 6.0, 7.0], "weights only": [1.0, 2.0, 3.0]},
              "worm": {"topology + weights": [3.0, 5.0, 6.0], "weights only": [4.0, 2.0, 1.0]}}
    figure = boxes_figure(panels, "v_x", "Figure 5", ("topology + weights", "weights only"))
    bars = [[t.get_text() for t in axes.texts] for axes in figure.axes]
    # worm: 8 of 9 pairs ahead: U = 8, one-sided p = 2/20, two-sided 4/20.
    assert bars == [["one-sided p = 0.05, two-sided p = 0.1"],
                    ["one-sided p = 0.1, two-sided p = 0.2"]]
    assert "one-sided p of H1 'topology + weights > weights only' (the paper's test)" in (
        figure.get_supxlabel())
    # The other figures (9, 11) keep the two-sided p alone.
    plain = boxes_figure(panels, "v_x", "Figure 11")
    assert [[t.get_text() for t in axes.texts] for axes in plain.axes] == [["p = 0.1"],
                                                                           ["p = 0.2"]]
    assert plain.get_supxlabel() == ""


def test_curves_align_runs_on_generations(tmp_path):
    long = load_run(fake_run(tmp_path, "a", {"shape": "worm"}, 4.0, n_generations=4))
    short_run = load_run(fake_run(tmp_path, "b", {"shape": "worm"}, 1.0, n_generations=2))
    generations, median, std = curve([long, short_run], "best_velocity")
    assert generations.tolist() == [0, 1, 2, 3]
    assert median.tolist() == pytest.approx([0.75, 1.5, 3.0, 4.0])
    assert std.tolist() == pytest.approx([0.25, 0.5, 0.0, 0.0])


def test_validation_velocity_is_read_where_logged_and_old_logs_still_load(tmp_path):
    run = load_run(fake_run(tmp_path, "a", {"shape": "worm"}, 4.0, n_generations=4))
    np.testing.assert_array_equal(run.log["validation_velocity"], [np.nan, 2 / 3, np.nan, 4 / 3])
    old = fake_run(tmp_path, "old", {"shape": "worm"}, 4.0, n_generations=2)
    lines = (old / "log.csv").read_text().splitlines()
    (old / "log.csv").write_text("\n".join(line.rsplit(",", 1)[0] for line in lines) + "\n")
    assert np.isnan(load_run(old).log["validation_velocity"]).all()
    assert load_run(old).final() == 4.0
    plot_runs([tmp_path / "a", old], tmp_path / "fig.png", group_by="shape", kind="curves")
    from matplotlib.figure import Figure

    axes = Figure().subplots()
    plot_validation(axes, {"worm": [run], "old": [load_run(old)]})
    [line] = axes.get_lines()  # the old run has nothing to draw
    assert line.get_xdata().tolist() == [1, 3] and "validation" in line.get_label()


# -- the command line ---------------------------------------------------------------------------


def one_line_error(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err and "Traceback" not in err
    for word in words:
        assert word in err
    return err


def test_bad_inputs_are_one_line_errors(tmp_path, capsys):
    genome_path = tmp_path / "worm.json"
    initial_genome(WORM, np.random.default_rng(0)).save(genome_path)
    no_log = fake_run(tmp_path, "nolog", {"shape": "worm"}, 1.0, drop_log=True)
    good = fake_run(tmp_path, "good", {"shape": "worm"}, 1.0)
    before = sorted(p.name for p in tmp_path.iterdir())
    one_line_error(capsys, ["plot", str(tmp_path / "missing"), "--out", str(tmp_path / "f.png")],
                   "missing", "no such run directory")
    one_line_error(capsys, ["plot", str(good), str(no_log), "--out", str(tmp_path / "f.png")],
                   "log.csv")
    one_line_error(capsys, ["plot", str(good), "--out", str(tmp_path / "f.jpg")], "extension")
    one_line_error(capsys, ["plot", str(good), "--group-by", "colour",
                            "--out", str(tmp_path / "f.png")], "group_by")
    one_line_error(capsys, ["draw", str(genome_path), "--partition", "biped-legs",
                            "--out", str(tmp_path / "b.png")], "partition", "1111/1111/1001")
    one_line_error(capsys, ["draw", str(genome_path), "--out", str(tmp_path / "b.jpg")],
                   "extension")
    one_line_error(capsys, ["show", str(genome_path), "--out", str(tmp_path / "w.avi")],
                   "extension")
    one_line_error(capsys, ["show", str(genome_path), "--frames", "3",
                            "--out", str(tmp_path / "w.mp4")], "frames")
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing half-written


def test_show_and_draw_commands_write_their_files(tmp_path, capsys):
    genome_path = tmp_path / "biped.json"
    initial_genome(BIPED, np.random.default_rng(0)).save(genome_path)
    strip = tmp_path / "strip.png"
    assert main(["show", str(genome_path), "--terrain", "flat", "--duration", "1",
                 "--frames", "3", "--brain", "--width", "64", "--height", "48",
                 "--out", str(strip)]) == 0
    with Image.open(strip) as image:
        assert image.size == (3 * 64 + 2 * 4, 48)
    assert main(["draw", str(genome_path), "--partition", "paper",
                 "--out", str(tmp_path / "brain.png")]) == 0
    assert "0 cut by the 3 modules" in capsys.readouterr().out


# -- layering ------------------------------------------------------------------------------------


def test_simulation_and_evolution_never_import_rendering():
    forbidden = {"viz", "matplotlib", "PIL", "imageio"}
    for package in ("sim", "brain", "tasks", "evolution", "modules"):
        for path in (SRC / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ImportFrom):
                    parts = set((node.module or "").split("."))
                    parts |= {alias.name for alias in node.names}
                elif isinstance(node, ast.Import):
                    parts = {part for alias in node.names for part in alias.name.split(".")}
                else:
                    continue
                assert not parts & forbidden, f"{path} imports {parts & forbidden}"
