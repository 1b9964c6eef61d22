"""Episodes to files: an MP4 or GIF video, or a PNG time-lapse strip (paper Figure 4).

:func:`render_episode` is the one-call entry point (``make demo`` uses it); ``somite show``
uses its two halves, :func:`record_episode` (the simulation, through the public
:func:`somite.tasks.locomotion.simulate_batch`) and :func:`write_episode` (the drawing and writing).
Every file is written to a temporary name beside the target and renamed when complete.
"""

from __future__ import annotations

import contextlib
import itertools
import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np
from PIL import Image

from ..brain.compile import compile_genome
from ..brain.controllers import Sine, Table, Zero
from ..brain.genome import Genome
from ..errors import bad
from ..sim.body import Body
from ..sim.config import SimConfig, preset
from ..sim.terrain import Terrain, parse_terrain
from ..tasks.locomotion import simulate_batch
from .brain import brain_overlay
from .frame import AREA_RAMP, Overlay, frame_steps, render_frames
from .output import atomic_output, check_output
from .recording import Recording
from .strip import render_strip

VIDEO_FORMATS = (".mp4", ".gif")
STRIP_FORMATS = (".png",)
OUTPUT_FORMATS = VIDEO_FORMATS + STRIP_FORMATS
VIDEO_SIZE = (960, 540)
TILE_SIZE = (320, 240)
DEFAULT_STRIP_FRAMES = 6


def record_episode(
    body: Body,
    controller: Genome | Zero | Sine | Table,
    terrain: Terrain | str = "hilly-1-10-0",
    config: SimConfig | None = None,
    seed: int = 0,
) -> Recording:
    """Simulate one robot with recording on and keep what the renderer needs.

    Parameters
    ----------
    body : Body
    controller : Genome or open-loop controller
        A genome is compiled to its graph controller; it must be of ``body``.
    terrain : Terrain or str
        A terrain or its name (``flat``, ``hilly-1-10-0``, ...).
    config : SimConfig, optional
        The paper preset by default.
    seed : int
        Seed of the sensor noise.

    Returns
    -------
    Recording
    """
    if isinstance(controller, Genome):
        if controller.body != body:
            raise bad("genome", controller.body.shape.grid_string(), "is not of this body")
        controller = compile_genome(controller)
    terrain = parse_terrain(terrain) if isinstance(terrain, str) else terrain
    config = config or preset("paper")
    [outcome], trace = simulate_batch([body], [terrain], [controller], config, seeds=seed,
                                      record=True)
    return Recording.from_trace(trace, 0, body, terrain, config, outcome.velocity)


def write_episode(
    recording: Recording,
    out_path: str | os.PathLike,
    fps: float = 30,
    width: int | None = None,
    height: int | None = None,
    genome: Genome | None = None,
    frames: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    speed: float = 1.0,
) -> Path:
    """Draw ``recording`` into ``out_path``: ``.mp4`` or ``.gif`` (a video at ``fps``, played
    at ``speed`` times real time: 0.25 is slow motion, 4 times as long) or ``.png`` (a strip
    of ``frames`` tiles, :data:`DEFAULT_STRIP_FRAMES` by default).

    ``width`` x ``height`` is the video's size (960 x 540 by default) or one tile's (320 x
    240). With ``genome``, the controller is drawn on the body. ``progress(done, total)`` is
    called after each video frame is drawn (rendering takes seconds).
    """
    out_path = check_output(out_path, OUTPUT_FORMATS)
    suffix = out_path.suffix.lower()
    overlays: list[Overlay] = [brain_overlay(genome)] if genome is not None else []
    if suffix in STRIP_FORMATS:
        w, h = frame_size(width, height, TILE_SIZE)
        strip = render_strip(recording, frames or DEFAULT_STRIP_FRAMES, w, h, overlays,
                             sensors=not overlays)
        with atomic_output(out_path) as tmp:
            strip.image.save(tmp, format="PNG", optimize=True)
        return out_path
    if frames is not None:
        raise bad("frames", frames, "a time-lapse strip is a .png; drop --frames for a video")
    # libx264 with yuv420p needs even sizes; rounding up here spares imageio's resize warning.
    w, h = (2 * ((n + 1) // 2) for n in frame_size(width, height, VIDEO_SIZE))
    images = (f.image for f in render_frames(recording, fps, w, h, overlays,
                                             sensors=not overlays, speed=speed))
    if progress is not None:
        images = _counted(images, len(frame_steps(recording.n_steps, fps, speed)), progress)
    return write_video(images, out_path, fps)


def _counted(images: Iterable[Image.Image], total: int, progress) -> Iterator[Image.Image]:
    for done, image in enumerate(images, 1):
        yield image
        progress(done, total)


def frame_size(width: int | None, height: int | None, default: tuple[int, int]) -> tuple[int, int]:
    """(width, height) in pixels, ``default`` filling what is None; one-line error if absurd."""
    w = default[0] if width is None else int(width)
    h = default[1] if height is None else int(height)
    for name, value in (("width", w), ("height", h)):
        if not 16 <= value <= 8192:
            raise bad(name, value, "must be between 16 and 8192 pixels")
    return w, h


def write_video(images: Iterable[Image.Image], out_path: str | os.PathLike, fps: float) -> Path:
    """Write RGB images of one size as an MP4 (H.264, through imageio-ffmpeg) or a GIF."""
    out_path = check_output(out_path, VIDEO_FORMATS)
    with atomic_output(out_path) as tmp:
        if out_path.suffix.lower() == ".mp4":
            _write_mp4(images, tmp, fps)
        else:
            _write_gif(images, tmp, fps)
    return out_path


def _write_mp4(images: Iterable[Image.Image], path: Path, fps: float) -> None:
    """Pipe the frames to ffmpeg (imageio-ffmpeg's binary) and check that it succeeded.

    Not imageio's writer: it never looks at ffmpeg's exit status, so a disk that fills up
    while ffmpeg writes (or its trailer) ends in a truncated file and no error. Here a failed
    ffmpeg is an OSError whose reason is ffmpeg's (:func:`_ffmpeg_reason`)."""
    import subprocess
    import tempfile
    from fractions import Fraction

    import imageio_ffmpeg

    iterator = iter(images)
    first = next(iterator, None)
    if first is None:
        raise bad("out", str(path), "a video needs at least one frame")
    width, height = first.size
    try:
        ffmpeg = imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError as error:  # no bundled binary for this platform, none on the PATH
        raise bad("out", str(path), f"cannot write an MP4 without ffmpeg ({error}); write a "
                  ".gif instead") from None
    command = [
        ffmpeg, "-y", "-f", "rawvideo", "-vcodec", "rawvideo",
        "-s", f"{width}x{height}", "-pix_fmt", "rgb24",
        "-r", str(Fraction(fps).limit_denominator()), "-i", "-", "-an",
        # crf 10: what imageio's quality=8 asked of libx264 before.
        "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", "10", "-v", "error", str(path),
    ]
    with tempfile.TemporaryFile() as log:  # not a pipe: ffmpeg could block on a full one
        process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                   stderr=log)
        try:
            try:
                for image in itertools.chain([first], iterator):
                    if image.size != (width, height):
                        raise ValueError(f"a frame of {image.size} in a video of "
                                         f"{(width, height)}")
                    rgb = image if image.mode == "RGB" else image.convert("RGB")
                    process.stdin.write(rgb.tobytes())
                process.stdin.close()
            except BrokenPipeError:  # ffmpeg quit (a full disk?): its exit status says why
                pass
            status = process.wait()
        except BaseException:
            process.kill()
            process.wait()
            raise
        finally:
            with contextlib.suppress(OSError):
                process.stdin.close()
        if status != 0:
            log.seek(0)
            raise OSError(_ffmpeg_reason(log.read().decode("utf-8", "replace"), status))


def _ffmpeg_reason(output: str, status: int) -> str:
    """Why ffmpeg failed in a few words: the OS's reason where it reports one (``No space
    left on device``), else its last line of error output."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    if not lines:
        return f"the encoder ffmpeg failed (exit status {status})"
    for known in ("No space left on device", "Permission denied", "Read-only file system",
                  "Disk quota exceeded", "File too large", "Input/output error"):
        if known in output:
            return known
    return f"the encoder ffmpeg failed: {lines[-1][:120]}"


def _write_gif(images: Iterable[Image.Image], path: Path, fps: float) -> None:
    iterator = iter(images)
    first = next(iterator)
    # One palette for all frames (no flicker), made from the first frame plus every colour a
    # voxel can take later on.
    palette = _gif_palette(first)
    frames = [_quantize(first, palette)] + [_quantize(image, palette) for image in iterator]
    # GIF delays are in 1/100 s: alternate them so that the mean matches fps (30 -> 30, 40 ms).
    ticks = np.round(np.arange(len(frames) + 1) * 100.0 / fps).astype(int)
    durations = [int(10 * d) for d in np.maximum(np.diff(ticks), 1)]
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:],
                   duration=durations, loop=0, optimize=False)


def _gif_palette(first: Image.Image) -> Image.Image:
    ramp = Image.new("RGB", (len(AREA_RAMP), 1))
    ramp.putdata([tuple(c) for c in AREA_RAMP])
    ramp = ramp.resize((first.width, 8), Image.Resampling.NEAREST)
    sample = Image.new("RGB", (first.width, first.height + 8))
    sample.paste(first, (0, 0))
    sample.paste(ramp, (0, first.height))
    return sample.quantize(colors=256, method=Image.Quantize.MEDIANCUT)


def _quantize(image: Image.Image, palette: Image.Image) -> Image.Image:
    return image.quantize(palette=palette, dither=Image.Dither.NONE)


def render_episode(
    genome: Genome | str | os.PathLike,
    out_path: str | os.PathLike,
    terrain_name: str = "hilly-1-10-0",
    duration: float | None = None,
    config: SimConfig | None = None,
    seed: int = 0,
    brain: bool = False,
    fps: float = 30,
    width: int | None = None,
    height: int | None = None,
    frames: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    speed: float = 1.0,
) -> Path:
    """Simulate ``genome`` on ``terrain_name`` and write the episode to ``out_path``.

    Parameters
    ----------
    genome : Genome or path
        The controller, or a genome JSON file.
    out_path : path
        ``.mp4``, ``.gif`` or ``.png`` (time-lapse strip, see :func:`write_episode`).
    terrain_name : str
        Any terrain name :func:`somite.sim.terrain.parse_terrain` reads.
    duration : float, optional
        Episode length [s]; the config's (30 s for the paper preset) by default.
    config : SimConfig, optional
        Simulation settings; the paper preset by default.
    seed : int
        Sensor-noise seed.
    brain : bool
        Draw the controller graph on the body.
    fps : float
        Video frame rate, at most 60 (the control rate); 30 shows every other step.
    width, height : int, optional
        Video size, or tile size for a strip.
    frames : int, optional
        Tiles of a ``.png`` strip.
    progress : callable, optional
        ``progress(done, total)`` after each video frame (:func:`write_episode`).
    speed : float
        Playback speed of a video, 0.05 (slow motion) to 4 times real time.

    Returns
    -------
    Path
        ``out_path``.
    """
    if not isinstance(genome, Genome):
        genome = Genome.load(genome)
    out_path = check_output(out_path, OUTPUT_FORMATS)
    config = config or preset("paper")
    if duration is not None:
        config = config.with_options(duration=float(duration))
    recording = record_episode(genome.body, genome, terrain_name, config, seed)
    return write_episode(recording, out_path, fps, width, height,
                         genome if brain else None, frames, progress, speed)


__all__: Sequence[str] = [
    "OUTPUT_FORMATS",
    "frame_size",
    "record_episode",
    "render_episode",
    "write_episode",
    "write_video",
]
