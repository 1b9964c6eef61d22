"""What a robot does, in numbers and in one line of words: a gait summary of a recorded episode.

From a recording (:class:`somite.viz.recording.Recording`, or anything with its ``actuation``,
``contact``, ``com``, ``corners``, ``body``, ``config`` and ``velocity``), over the measured part
of the episode (after the transient):

- per voxel, the dominant frequency of its actuation (the highest peak of its spectrum, the
  mean removed), how far it swings (half the 5th-95th percentile range), its phase at the
  robot's main frequency (relative to the first moving voxel from the back), whether it is
  still (swings less than :data:`STILL_AMPLITUDE`), and its duty factor (the share of steps in
  which one of its corners touches the ground);
- the robot's main actuation frequency (the peak, from :data:`MIN_RHYTHM_HZ` up, of the summed
  spectra of the moving voxels) and the stride frequency of its centre of mass (the peak, from
  :data:`MIN_STRIDE_HZ` up, of the spectrum of its horizontal velocity, its linear trend
  removed);
- a pattern and a one-line description: a few voxels vibrating while the rest hold a pose,
  a travelling wave (back to front or front to back), voxels pulsing together or in two
  alternating groups, or no simple pattern.

Numbers only: the picture is :func:`somite.viz.gait.draw_gait`.

See docs/decisions.md, "Watching robots".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..sim.config import CONTROL_HZ

STILL_AMPLITUDE = 0.05
"""A voxel whose actuation swings by less than this (half its 5-95 % range) is still."""
VIBRATION_HZ = 4.0
"""A voxel moving at this frequency or faster vibrates; slower, it swings."""
FEW_MOVING = 1 / 3
"""At most this share of the voxels moving: "a few voxels move, the rest hold a pose"."""
STANDING = 0.05
"""|v_x| [m/s] below which the robot "barely moves"."""
MIN_WAVE = math.pi / 3
"""Phase change [rad] across the body from which a coherent phase slope is a travelling wave."""
COHERENT = 0.8
"""How well the phases must follow a line (the length of the mean residual phasor, 0..1)."""
MIN_STRIDE_HZ = 0.5
"""The stride frequency is looked for from here up: slower changes of v_x are drift."""
MIN_RHYTHM_HZ = 0.2
"""The main actuation frequency is looked for from here up (5 cycles over the 25 s measured):
a slower swing is a drift of posture, and named the main frequency it made a robot vibrating
at 12 Hz "pulse at 0 Hz"."""


@dataclass(frozen=True)
class VoxelGait:
    """One voxel's part in the gait."""

    voxel: int
    x: int
    y: int
    frequency: float  # [Hz] dominant frequency of its actuation (0 when still)
    amplitude: float  # half the 5th-95th percentile range of its actuation
    phase: float  # [rad] at the robot's main frequency, relative to the reference voxel
    mean: float  # mean actuation (the pose it holds when still)
    still: bool
    duty: float  # share of the steps with one of its corners on the ground


@dataclass(frozen=True)
class Gait:
    """The gait of one recorded episode (see the module's docstring)."""

    voxels: tuple[VoxelGait, ...]
    frequency: float  # [Hz] main actuation frequency (0 when every voxel is still)
    stride_frequency: float  # [Hz] of the centre of mass's horizontal velocity
    velocity: float  # [m/s] the episode's v_x
    pattern: str  # still, vibration, swing, wave-forward, wave-backward, together,
    # alternating, mixed
    description: str
    start: float  # [s] the analysed interval
    end: float
    frequencies: np.ndarray  # (F,) [Hz] the spectra's frequencies
    spectra: np.ndarray  # (V, F) amplitude spectrum of each voxel's actuation
    stride_spectrum: np.ndarray  # (F,) amplitude spectrum of the centre of mass's v_x

    @property
    def still(self) -> list[int]:
        return [v.voxel for v in self.voxels if v.still]

    @property
    def moving(self) -> list[int]:
        return [v.voxel for v in self.voxels if not v.still]

    def to_dict(self) -> dict:
        """JSON-ready numbers (spectra left out)."""
        return {
            "description": self.description,
            "pattern": self.pattern,
            "frequency_hz": self.frequency,
            "stride_frequency_hz": self.stride_frequency,
            "velocity": self.velocity,
            "interval_s": [self.start, self.end],
            "still_voxels": self.still,
            "voxels": [
                {"voxel": v.voxel, "x": v.x, "y": v.y, "frequency_hz": v.frequency,
                 "amplitude": v.amplitude, "phase_deg": math.degrees(v.phase),
                 "mean": v.mean, "still": v.still, "duty_factor": v.duty}
                for v in self.voxels
            ],
        }

    def table(self) -> str:
        """A plain-text table, one voxel a row."""
        lines = [f"{'voxel':>5} {'(x,y)':>7} {'freq Hz':>8} {'swing':>6} {'phase':>7} "
                 f"{'mean':>6} {'ground':>7}"]
        for v in self.voxels:
            freq = "still" if v.still else f"{v.frequency:.2f}"
            phase = "" if v.still else f"{math.degrees(v.phase):+.0f} deg"
            lines.append(f"{v.voxel:>5} {f'({v.x},{v.y})':>7} {freq:>8} {v.amplitude:>6.2f} "
                         f"{phase:>7} {v.mean:>+6.2f} {100 * v.duty:>6.0f}%")
        return "\n".join(lines)


def _spectrum(signal: np.ndarray, n: int) -> np.ndarray:
    """Amplitude spectrum (..., n // 2 + 1) of rows of ``signal`` with their mean removed: a
    sinusoid of amplitude A gives a peak of about A at its frequency."""
    centred = signal - signal.mean(axis=-1, keepdims=True)
    return 2.0 * np.abs(np.fft.rfft(centred, n=n, axis=-1)) / max(signal.shape[-1], 1)


def analyse_gait(recording) -> Gait:
    """The gait of ``recording`` (see the module's docstring)."""
    body, config = recording.body, recording.config
    voxels = body.shape.voxels
    n_voxels = len(voxels)
    rows = len(recording.actuation)
    # The steps after the transient (after step 0, the state before any control, when the
    # episode is too short for a transient): n_steps - transient_steps samples, whole seconds
    # when the durations are.
    first = config.transient_steps if rows - config.transient_steps > 2 * CONTROL_HZ else 0
    first = min(first + 1, max(rows - 2, 0))
    act = np.asarray(recording.actuation[first:], dtype=np.float64).T  # (V, T)
    n = act.shape[1]
    freqs = np.fft.rfftfreq(max(n, 2), d=1.0 / CONTROL_HZ)
    spectra = _spectrum(act, max(n, 2)) if n else np.zeros((n_voxels, len(freqs)))
    lo, hi = np.percentile(act, [5, 95], axis=1) if n else (np.zeros(n_voxels),) * 2
    amplitude = 0.5 * (hi - lo)
    still = amplitude < STILL_AMPLITUDE
    peak = np.argmax(spectra[:, 1:], axis=1) + 1 if len(freqs) > 1 else np.zeros(n_voxels, int)
    moving = np.flatnonzero(~still)
    rhythm = np.flatnonzero(freqs >= MIN_RHYTHM_HZ)
    if len(moving) and len(rhythm):
        main_bin = int(rhythm[np.argmax(spectra[moving][:, rhythm].sum(axis=0))])
        main = float(freqs[main_bin])
        phasor = np.fft.rfft(act - act.mean(axis=1, keepdims=True), axis=1)[:, main_bin]
        back = moving[np.argmin([voxels[v][0] for v in moving])]
        phase = np.angle(phasor * np.conj(phasor[back]))
    else:
        main, phase = 0.0, np.zeros(n_voxels)
    # Contacts: a voxel is on the ground when one of its corners is.
    contact = np.asarray(recording.contact[first:], dtype=bool)
    corners = np.asarray(recording.corners)
    duty = contact[:, corners].any(axis=2).mean(axis=0) if len(contact) else np.zeros(n_voxels)
    com = np.asarray(recording.com[max(first - 1, 0):], dtype=np.float64)
    if len(com) > 2:
        vx = np.diff(com[:, 0]) * CONTROL_HZ
        time = np.arange(len(vx))
        vx = vx - np.polyval(np.polyfit(time, vx, 1), time)  # the drift out
        stride_spectrum = np.interp(freqs, np.fft.rfftfreq(len(vx), 1.0 / CONTROL_HZ),
                                    _spectrum(vx, len(vx)))
        band = np.flatnonzero(freqs >= MIN_STRIDE_HZ)
        stride = float(freqs[band[np.argmax(stride_spectrum[band])]]) if len(band) else 0.0
    else:
        stride_spectrum, stride = np.zeros(len(freqs)), 0.0
    rows_out = tuple(
        VoxelGait(
            voxel=v, x=int(voxels[v][0]), y=int(voxels[v][1]),
            frequency=0.0 if still[v] else float(freqs[peak[v]]),
            amplitude=float(amplitude[v]),
            phase=0.0 if still[v] else float(phase[v]),
            mean=float(act[v].mean()) if n else 0.0,
            still=bool(still[v]),
            duty=float(duty[v]),
        )
        for v in range(n_voxels)
    )
    velocity = float(recording.velocity)
    pattern, words = describe_gait(rows_out, main, velocity)
    return Gait(rows_out, main, stride, velocity, pattern, words, max(first - 1, 0) / CONTROL_HZ,
                (rows - 1) / CONTROL_HZ if rows else 0.0, freqs, spectra, stride_spectrum)


def _listing(numbers: list[int]) -> str:
    text = [str(v) for v in numbers]
    return text[0] if len(text) == 1 else ", ".join(text[:-1]) + " and " + text[-1]


def _hz(f: float) -> str:
    # Two significant digits below 1 Hz: a 25 s window resolves 0.04 Hz, which "0.0" hid.
    text = f"{f:.2g}" if f < 0.95 else f"{f:.1f}" if f < 9.95 else f"{f:.0f}"
    return f"{text.removesuffix('.0')} Hz"


def describe_gait(voxels: tuple[VoxelGait, ...], main: float, velocity: float
                  ) -> tuple[str, str]:
    """(pattern, one line of words) from the per-voxel figures, the main frequency [Hz] and
    v_x [m/s] (see the module's docstring)."""
    moving = [v for v in voxels if not v.still]
    if not math.isfinite(velocity):
        motion = "the simulation went non-finite"
    elif abs(velocity) < STANDING:
        motion = "it barely moves"
    else:
        motion = f"{'forward' if velocity > 0 else 'backward'} at {abs(velocity):.2f} m/s"
    if not moving:
        return "still", f"every voxel holds a pose; {motion}"
    if len(moving) <= max(1, int(FEW_MOVING * len(voxels))):
        # Each moving voxel at its own frequency, those at the same one named together.
        groups: dict[str, list[int]] = {}
        for v in sorted(moving, key=lambda v: (-v.frequency, v.voxel)):
            groups.setdefault(_hz(v.frequency), []).append(v.voxel)
        fast = any(v.frequency >= VIBRATION_HZ for v in moving)
        parts = []
        for hz, ids in groups.items():
            rate = float(hz.split()[0])
            verb = "vibrate" if rate >= VIBRATION_HZ else "swing" if rate >= MIN_RHYTHM_HZ \
                else "drift"
            verb += "s" if len(ids) == 1 else ""
            parts.append(f"{'voxel' if len(ids) == 1 else 'voxels'} {_listing(ids)} {verb} "
                         f"at {hz}")
        rest = ", the rest hold a pose" if len(moving) < len(voxels) else ""
        how = f"progress by vibration, {motion}" if fast and abs(velocity) >= STANDING else motion
        return ("vibration" if fast else "swing", f"{', '.join(parts)}{rest}; {how}")
    x = np.array([v.x for v in moving], dtype=np.float64)
    phase = np.array([v.phase for v in moving])
    columns = np.unique(x)
    if len(columns) >= 3:
        # The phase per column (circular mean), unwrapped from the back to the front.
        mean = np.array([np.angle(np.exp(1j * phase[x == c]).mean()) for c in columns])
        line = np.unwrap(mean)
        slope = np.polyfit(columns, line, 1)[0]
        fit = abs(np.exp(1j * (mean - slope * columns)).mean())
        span = slope * (columns[-1] - columns[0])
        if abs(span) >= MIN_WAVE and fit >= COHERENT:
            # a = A cos(2 pi f t + phi): a phase falling with x peaks later further along +x.
            towards_plus_x = slope < 0
            ahead = velocity >= 0 or not math.isfinite(velocity)
            direction = "back to front" if towards_plus_x == ahead else "front to back"
            pattern = "wave-forward" if direction == "back to front" else "wave-backward"
            return pattern, (f"travelling wave {direction} at {_hz(main)} "
                             f"({len(moving)} of {len(voxels)} voxels); {motion}")
    spread = np.abs(np.angle(np.exp(1j * phase)))
    if np.all(spread <= math.pi / 4):
        return "together", f"the voxels pulse together at {_hz(main)}; {motion}"
    if np.all((spread <= math.pi / 4) | (spread >= 3 * math.pi / 4)):
        return "alternating", (f"two groups of voxels pulse in alternation at {_hz(main)}; "
                               f"{motion}")
    return "mixed", (f"{len(moving)} of {len(voxels)} voxels move, mostly at {_hz(main)}, "
                     f"without a simple pattern; {motion}")


__all__ = [
    "Gait",
    "STILL_AMPLITUDE",
    "VoxelGait",
    "analyse_gait",
    "describe_gait",
]
