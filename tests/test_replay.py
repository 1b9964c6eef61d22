"""The replay page (``somite show --out walk.html``), in a real headless Chromium where one is
installed, and slow motion of videos."""

from __future__ import annotations

import base64
import gc
import json
import re
import shutil
import subprocess
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from somite.brain.controllers import Sine
from somite.cli import main
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.sim.body import Body
from somite.sim.config import CONTROL_HZ, preset
from somite.viz.frame import frame_steps
from somite.viz.replay import ReplayRun, node_activity, replay_html, write_replay
from somite.viz.video import record_episode, write_episode

WORM = Body.build("worm")
CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")
                 if shutil.which(n)), None)
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium on the PATH (Debian: apt-get install chromium), so the "
    "replay page is not loaded in a browser")


def browser(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    """Headless Chromium with a profile of its own, its console logged to stderr."""
    command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-extensions", "--hide-scrollbars", "--allow-file-access-from-files",
               f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
               *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=900)


def page_state(tmp_path: Path, page: Path, fragment: str) -> tuple[dict, str]:
    """The DOM's root and body attributes after loading ``page#fragment``, and the console."""
    done = browser(tmp_path, "--dump-dom", f"{page.resolve().as_uri()}#{fragment}")
    assert done.returncode == 0, done.stderr[-2000:]
    root = re.search(r"<html([^>]*)>", done.stdout).group(1)
    body = re.search(r"<body([^>]*)>", done.stdout).group(1)
    attrs = dict(re.findall(r'([\w-]+)="([^"]*)"', root + " " + body))
    return {k: v.replace("&quot;", '"').replace("&amp;", "&") for k, v in attrs.items()}, \
        done.stderr


@pytest.fixture(scope="module")
def worm_runs():
    config = preset("paper", duration=2.0)
    genome = initial_genome(WORM, np.random.default_rng(3))
    graph = record_episode(WORM, genome, "hilly-1-10-0", config, seed=1)
    sine = record_episode(WORM, Sine(freq=2.0), "hilly-1-10-0", config, seed=1)
    return genome, graph, sine


def decoded_payload(text: str) -> dict:
    data = re.search(r'<script id="somite-data" type="application/json">(.*?)</script>', text,
                     re.S).group(1)
    return json.loads(data)


# -- without a browser --------------------------------------------------------------------------


def test_node_activity_replays_the_recorded_actuation(worm_runs):
    genome, graph, _ = worm_runs
    h = node_activity(genome, graph)
    assert h.shape == (len(graph.actuation), genome.n_nodes)
    actuators = [i for i, n in enumerate(genome.nodes) if n.kind == "actuator"]
    voxel = [WORM.shape.voxels.index((genome.nodes[i].x, genome.nodes[i].y)) for i in actuators]
    np.testing.assert_allclose(h[1:, actuators], graph.actuation[1:, voxel], atol=1e-9)
    assert np.all(np.abs(h) <= 1)


def test_page_is_one_file_holding_the_recording_compactly(tmp_path, worm_runs):
    genome, graph, sine = worm_runs
    out = write_replay([ReplayRun(graph, genome, "graph"), ReplayRun(sine, None, "sine")],
                       tmp_path / "cmp.html", speed=0.25)
    text = out.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cmp.html"]
    # No server, no network: nothing is fetched from anywhere.
    assert not re.search(r"(src|href)\s*=|https?://|import\(|fetch\(", text)
    data = decoded_payload(text)
    assert data["speed"] == 0.25
    first = data["runs"][0]
    assert first["steps"] == len(graph.pos) and first["brain"] is not None
    assert data["runs"][1]["brain"] is None
    # int16 offsets from the centre of mass give the corners back to within half a step.
    com = np.frombuffer(base64.b64decode(first["com"]), "<f8").reshape(-1, 2)
    offsets = np.frombuffer(base64.b64decode(first["pos"]), "<i2").reshape(
        len(graph.pos), -1, 2)
    pos = com[:, None, :] + offsets * first["posScale"]
    assert np.abs(pos - graph.pos).max() <= first["posScale"]
    contact = np.unpackbits(np.frombuffer(base64.b64decode(first["contact"]), "u1"))
    assert contact[: graph.contact.size].tolist() == graph.contact.ravel().tolist()


def test_a_30_s_worm_page_stays_under_2_mb(tmp_path):
    genome = initial_genome(WORM, np.random.default_rng(0))
    recording = record_episode(WORM, genome, "hilly-1-10-0", preset("paper"), seed=0)
    assert recording.n_steps == 30 * CONTROL_HZ
    size = len(replay_html([ReplayRun(recording, genome)]).encode())
    assert size < 2e6, size


def test_show_refuses_bad_speed_and_several_genomes_in_a_video(tmp_path, capsys):
    path = tmp_path / "worm.json"
    initial_genome(WORM, np.random.default_rng(0)).save(path)
    for argv, words in (
        (["show", str(path), "--speed", "5", "--out", str(tmp_path / "w.gif")], "speed"),
        (["show", str(path), "--speed", "0.01", "--out", str(tmp_path / "w.html")], "speed"),
        (["show", str(path), str(path), "--out", str(tmp_path / "w.mp4")], ".html"),
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["worm.json"]


# -- slow motion --------------------------------------------------------------------------------


@pytest.mark.parametrize("speed", [0.05, 0.25, 0.5, 1.0, 2.0, 4.0])
def test_frame_steps_play_at_speed(speed):
    steps = frame_steps(120, 30, speed)
    assert len(steps) == round(120 / CONTROL_HZ / speed * 30)
    assert steps[0] == 0 and np.all(np.diff(steps) >= 0)
    # Frame k shows time k * speed / fps, to the nearest step.
    assert np.all(np.abs(steps / CONTROL_HZ - np.arange(len(steps)) * speed / 30)
                  <= 0.5 / CONTROL_HZ + 1e-12)
    with pytest.raises(SomiteError, match="speed"):
        frame_steps(120, 30, 4.5)


@pytest.mark.parametrize("speed,fps", [(0.25, 30), (0.5, 24), (1.0, 30), (2.0, 20), (4.0, 30)])
def test_gif_plays_for_the_duration_over_speed(tmp_path, worm_runs, speed, fps):
    _, _, sine = worm_runs
    short = replace(sine, pos=sine.pos[:31], actuation=sine.actuation[:31],
                    readings=sine.readings[:31], contact=sine.contact[:31], com=sine.com[:31])
    out = write_episode(short, tmp_path / "slow.gif", fps=fps, width=48, height=32,
                        speed=speed)
    with Image.open(out) as gif:
        delays = []
        for k in range(gif.n_frames):
            gif.seek(k)
            delays.append(gif.info["duration"])
    # The delays alternate in 1/100 s (30 and 40 ms at 30 fps) and add up to the episode's
    # duration over the speed, to within half a frame.
    real = short.n_steps / CONTROL_HZ / speed * 1000
    assert abs(sum(delays) - real) <= 500 / fps + 10
    assert set(delays) <= {10 * t for t in range(1, 10_000)}


@pytest.mark.parametrize("speed", [0.25, 2.0])
def test_mp4_has_duration_over_speed_times_fps_frames(tmp_path, worm_runs, speed):
    import imageio.v3 as iio

    _, _, sine = worm_runs
    short = replace(sine, pos=sine.pos[:31], actuation=sine.actuation[:31],
                    readings=sine.readings[:31], contact=sine.contact[:31], com=sine.com[:31])
    out = write_episode(short, tmp_path / "slow.mp4", fps=20, width=48, height=32, speed=speed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)  # imageio-ffmpeg's reader's pipes
        frames = iio.imread(out, index=None)
        gc.collect()
    assert len(frames) == round(0.5 / speed * 20)


# -- in a browser -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def compare_page(tmp_path_factory, worm_runs):
    genome, graph, sine = worm_runs
    folder = tmp_path_factory.mktemp("page")
    return write_replay([ReplayRun(graph, genome, "graph"), ReplayRun(sine, None, "sine")],
                        folder / "cmp.html")


@needs_chromium
@pytest.mark.parametrize("fragment", ["t=1.25&probe", "t=1.25&probe&ghosts&act&speed=0.05"])
def test_scrubbing_to_t_shows_the_robot_where_the_trace_has_it(tmp_path, worm_runs,
                                                              compare_page, fragment):
    _, graph, sine = worm_runs
    attrs, console = page_state(tmp_path, compare_page, fragment)
    assert attrs.get("data-ready") == "1", console[-2000:]
    assert "data-errors" not in attrs, attrs["data-errors"]
    assert "Uncaught" not in console
    probe = json.loads(attrs["data-probe"])
    step = round(1.25 * CONTROL_HZ)
    for shown, recording in zip(probe, (graph, sine)):
        assert shown["step"] == step and shown["t"] == pytest.approx(1.25)
        assert shown["x"] == pytest.approx(recording.com[step, 0], abs=1e-12)
        assert shown["v"] == pytest.approx(recording.velocity_at(step), abs=1e-9)
        reach = np.abs(recording.pos - recording.com[:, None, :]).max() / 32000
        assert np.abs(np.array(shown["points"]) - recording.pos[step]).max() <= reach


HOSTILE_NAME = "x<!--<script></script>&\u2028"
"""A genome file's name that ended the page's data early (issue 71): a blank page."""


def test_a_run_name_cannot_end_the_pages_data(worm_runs, tmp_path):
    genome, graph, _ = worm_runs
    page = write_replay([ReplayRun(graph, genome, HOSTILE_NAME)], tmp_path / "p.html").read_text()
    block = re.search(r'type="application/json">(.*?)</script>', page, re.S).group(1)
    assert not set("<>&\u2028") & set(block)
    assert decoded_payload(page)["runs"][0]["name"] == HOSTILE_NAME


@needs_chromium
def test_a_page_of_a_hostile_run_name_plays_and_shows_it(tmp_path, worm_runs):
    genome, graph, _ = worm_runs
    page = write_replay([ReplayRun(graph, genome, HOSTILE_NAME)], tmp_path / "p.html",
                        title=HOSTILE_NAME)
    attrs, console = page_state(tmp_path, page, "t=0.5&probe")
    assert attrs.get("data-ready") == "1" and "data-errors" not in attrs, console[-2000:]
    assert json.loads(attrs["data-probe"])[0]["step"] == 30


@needs_chromium
def test_frame_keys_step_and_change_speed(tmp_path, compare_page):
    steps = ["ArrowRight", "ArrowRight", "ArrowRight", "ArrowLeft", "shift%2BArrowRight"]
    attrs, console = page_state(tmp_path, compare_page, f"t=0.5&probe&keys={','.join(steps)}")
    assert attrs.get("data-ready") == "1" and "data-errors" not in attrs, console[-2000:]
    assert json.loads(attrs["data-probe"])[0]["step"] == 30 + 3 - 1 + round(CONTROL_HZ)
    more = ["End", "ArrowLeft", "%5D", "%5D"]  # "]": twice as fast
    attrs, _ = page_state(tmp_path, compare_page, f"t=0.5&probe&speed=0.5&keys={','.join(more)}")
    first, second = json.loads(attrs["data-probe"])
    last = 2 * round(CONTROL_HZ)  # two seconds recorded
    assert first["step"] == second["step"] == last - 1
    assert first["speed"] == 2.0


@needs_chromium
def test_page_readout_and_screenshot(tmp_path, compare_page):
    done = browser(tmp_path, "--dump-dom", compare_page.resolve().as_uri() + "#t=0.5")
    assert done.returncode == 0, done.stderr[-2000:]
    readout = re.search(r'id="readout0"[^>]*>([^<]*)<', done.stdout)
    assert readout and "t = 0.500 s" in readout.group(1) and "step 30/" in readout.group(1)
    shot = tmp_path / "shot.png"
    done = browser(tmp_path, f"--screenshot={shot}", "--window-size=1100,1000",
                   compare_page.resolve().as_uri() + "#t=1")
    assert done.returncode == 0 and shot.exists(), done.stderr[-2000:]
    with Image.open(shot) as image:
        pixels = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(int)
    colours = {tuple(p) for p in pixels[:: 7]}
    assert len(colours) > 200  # terrain, voxels, text, the brain panel: not a blank page
    sky = (np.abs(pixels - [236, 242, 248]).sum(axis=1) <= 3).mean()
    ground = (np.abs(pixels - [152, 141, 124]).sum(axis=1) <= 3).mean()
    assert sky > 0.05 and ground > 0.02


def test_show_writes_one_page_for_several_genomes_and_says_their_gaits(tmp_path, capsys):
    paths = []
    for seed in (0, 1):
        paths.append(tmp_path / f"worm{seed}.json")
        initial_genome(WORM, np.random.default_rng(seed)).save(paths[-1])
    out = tmp_path / "cmp.html"
    assert main(["show", *map(str, paths), "--terrain", "flat", "--duration", "1",
                 "--speed", "0.5", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.count("gait: ") == 2 and f"wrote {out}" in printed
    data = decoded_payload(out.read_text())
    assert [r["name"] for r in data["runs"]] == ["worm0", "worm1"] and data["speed"] == 0.5
    assert all(r["gait"] and r["terrain"] == "flat" for r in data["runs"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cmp.html", "worm0.json",
                                                          "worm1.json"]
