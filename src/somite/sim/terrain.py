"""Terrains: piecewise-linear ground profiles, 2000 m long, with a steep wall at each end.

Names follow the authors' simulator (docs/original-system.md section 1.5; docs/decisions.md,
"Terrains"): ``flat``, ``hilly-H-W-SEED``, ``steppy-H-W-SEED``, ``uphill-DEG`` and ``downhill-DEG``.
``hilly`` is generated exactly as the authors' code does, with a re-implementation of
``java.util.Random``, so that ``hilly-1-10-42`` is the same profile in somite and in the original.

Each terrain has exactly one name (:func:`parse_terrain` refuses any other spelling and says the
right one), so that names can be compared: a validation terrain cannot be trained on under
another spelling. The numbers of a name:

- H (height steps) and W (segment or step width) [m]: a decimal number, 0 <= H <= 1000 and
  0 < W <= 1000, written as the shortest decimal that reads back as the same float, without
  exponent, sign, leading zeros or trailing zeros: ``1`` not ``1.0`` or ``01``, ``0.5`` not
  ``.5`` or ``0.50``;
- SEED: a whole number in [0, 2**63) (a Java long), without leading zeros: ``10000`` not
  ``010000``;
- DEG: a decimal like H, 0 <= DEG < 60;
- no number has more than :data:`MAX_NUMBER_CHARS` characters.

The same grammar names the training distributions (:mod:`somite.tasks.distributions`): the last
number replaced by ``rnd`` (``hilly-1-10-rnd``, ``uphill-rnd``) is drawn afresh per evaluation.
Every kind, with its numbers, its builder and its draw, is one entry of :data:`TERRAIN_KINDS`; the
parsers and the help texts are written from it.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._jit import njit
from ..errors import bad
from .java_random import MASK, MULT, JavaRandom, next_double

LENGTH = 2000.0
WALL_WIDTH = 10.0
WALL_HEIGHT = 100.0
STEP_RISER = 0.05
"""Horizontal extent of a step's riser on steppy terrains, so that x stays strictly increasing."""


@dataclass(frozen=True, eq=False)
class Terrain:
    """A ground profile y(x): vertices with strictly increasing x, in metres.

    The first and last segments are the walls; ``start_x`` is the foot of the left wall.
    """

    name: str
    xs: np.ndarray
    ys: np.ndarray

    def __post_init__(self) -> None:
        # Checked, as NaN or unordered vertices give NaN physics without an error; and kept
        # read-only copies, as a terrain is shared (cached by name, one for a whole batch):
        # a caller's write would change the ground of episodes it never meant to.
        if not isinstance(self.name, str):
            raise bad("terrain.name", self.name, "a terrain's name is a string")
        xs, ys = (_vertices(f"terrain.{f}", getattr(self, f)) for f in ("xs", "ys"))
        if len(xs) < 2 or ys.shape != xs.shape:
            raise bad("terrain.ys", f"{len(ys)} heights", f"need one per x ({len(xs)}), and "
                      "two vertices at least")
        if not (np.diff(xs) > 0).all():
            raise bad("terrain.xs", float(xs[1 + int(np.argmin(np.diff(xs) > 0))]),
                      "the x of the vertices must be strictly increasing")
        object.__setattr__(self, "xs", xs)
        object.__setattr__(self, "ys", ys)

    @property
    def start_x(self) -> float:
        return float(self.xs[1])

    def height_at(self, x: float | np.ndarray) -> np.ndarray:
        """Ground height under x (linear interpolation between vertices)."""
        return np.interp(x, self.xs, self.ys)


def _vertices(field: str, values) -> np.ndarray:
    """A read-only float64 copy of ``values``: a 1-D array of finite numbers."""
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise bad(field, values, "expected a 1-D array of numbers") from None
    if array.ndim != 1:
        raise bad(field, f"shape {array.shape}", "expected a 1-D array of numbers")
    if not np.isfinite(array).all():
        raise bad(field, float(array[np.argmin(np.isfinite(array))]), "every value must be "
                  "finite")
    array.flags.writeable = False
    return array


def _walled(inner_x: list[float], inner_y: list[float], name: str) -> Terrain:
    """Add the walls: up WALL_HEIGHT above the neighbouring ground at both ends."""
    xs = [0.0] + inner_x + [inner_x[-1] + WALL_WIDTH]
    ys = [inner_y[0] + WALL_HEIGHT] + inner_y + [inner_y[-1] + WALL_HEIGHT]
    return Terrain(name, np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))


def flat() -> Terrain:
    return _walled([WALL_WIDTH, LENGTH - WALL_WIDTH], [0.0, 0.0], "flat")


@njit
def _hilly_walk(seed, height, width, end_x, wall_width, wall_height):
    """The authors' hilly profile (see :func:`hilly`) with java.util.Random, compiled: a
    training run builds a fresh terrain for every evaluation."""
    state = (np.uint64(seed) ^ MULT) & MASK
    cached = 0.0
    has_cached = False
    capacity = int(end_x) + 8  # segments are at least 1 m long
    xs = np.empty(capacity)
    ys = np.empty(capacity)
    xs[0], ys[0], xs[1], ys[1] = 0.0, wall_height, wall_width, 0.0
    n = 2
    draws = np.empty(2)
    while xs[n - 1] < end_x:
        for k in range(2):  # the x step first, then the height step
            if has_cached:
                draws[k] = cached
                has_cached = False
                continue
            while True:
                u, state = next_double(state)
                v, state = next_double(state)
                v1 = 2.0 * u - 1.0
                v2 = 2.0 * v - 1.0
                s = v1 * v1 + v2 * v2
                if 0.0 < s < 1.0:
                    break
            multiplier = math.sqrt(-2.0 * math.log(s) / s)
            cached = v2 * multiplier
            has_cached = True
            draws[k] = v1 * multiplier
        xs[n] = xs[n - 1] + max(1.0, (draws[0] * 0.25 + 1.0) * width)
        ys[n] = ys[n - 1] + draws[1] * height
        n += 1
    xs[n] = xs[n - 1] + wall_width
    ys[n] = wall_height
    return xs[: n + 1].copy(), ys[: n + 1].copy()


def hilly(height: float, width: float, seed: int) -> Terrain:
    """The authors' random walk of heights (docs/original-system.md section 1.5), bit for bit."""
    xs, ys = _hilly_walk(int(seed), float(height), float(width), LENGTH - WALL_WIDTH,
                         WALL_WIDTH, WALL_HEIGHT)
    return Terrain(hilly_name(height, width, seed), xs, ys)


def hilly_name(height: float, width: float, seed: int) -> str:
    """The name of :func:`hilly`'s terrain, without building it."""
    return f"hilly-{_fmt(height)}-{_fmt(width)}-{seed}"


def steppy(height: float, width: float, seed: int) -> Terrain:
    """Flat steps of random width N(W, (W/4)^2) >= 1 and random height steps N(0, H^2)."""
    rng = JavaRandom(seed)
    xs = [WALL_WIDTH]
    ys = [0.0]
    while xs[-1] < LENGTH - WALL_WIDTH:
        step_width = max(1.0, (rng.next_gaussian() * 0.25 + 1) * width)
        xs.append(xs[-1] + step_width)
        ys.append(ys[-1])
        xs.append(xs[-1] + STEP_RISER)
        ys.append(ys[-1] + rng.next_gaussian() * height)
    return _walled(xs, ys, f"steppy-{_fmt(height)}-{_fmt(width)}-{seed}")


def slope(degrees: float, name: str) -> Terrain:
    rise = math.tan(math.radians(degrees)) * (LENGTH - 2 * WALL_WIDTH)
    return _walled([WALL_WIDTH, LENGTH - WALL_WIDTH], [0.0, rise], name)


def _fmt(value: float) -> str:
    """A number as a terrain name writes it: the shortest decimal that reads back as
    ``value``, positional (``0.00001``, not ``1e-05``), ``1`` for 1.0."""
    return np.format_float_positional(float(value), trim="-")


MAX_SIZE = 1000.0
"""The largest H and W [m] of a hilly or steppy terrain."""
MAX_SLOPE = 60.0
"""Slopes are under this many degrees."""
MAX_SEED = 2**63
"""SEED is below this (a Java long)."""
MAX_NUMBER_CHARS = 30
"""The most characters of one number in a terrain name (checked before it is read)."""
N_TRAINING_SEEDS = 10000
"""``hilly-H-W-rnd`` and ``steppy-H-W-rnd`` draw SEED from [0, 10000), as the original does;
the validation terrains' seeds start here (:mod:`somite.tasks.validation`)."""
MAX_SLOPE_DEG = 10.0
SLOPE_STEP_DEG = 0.5
"""``uphill-rnd`` and ``downhill-rnd`` draw DEG from {0, 0.5, ..., 10}."""
RANDOM = "rnd"
"""In a distribution's name, the number drawn afresh for every evaluation."""


# -- the terrain kinds: one grammar for fixed terrains and distributions -------------------------


@dataclass(frozen=True)
class Field:
    """One number of a terrain name.

    ``letter`` names it in the grammar and in errors; ``bounds`` says its accepted values in
    the help; ``checks`` are (test, reason) pairs: a value failing a test is refused with its
    reason, which names ``letter``; ``whole`` numbers are integers (else decimals);
    ``example`` is a value it may take (the tests build every kind from them)."""

    letter: str
    bounds: str
    checks: tuple[tuple[Callable[[float], bool], str], ...]
    example: float
    whole: bool = False


@dataclass(frozen=True)
class TerrainKind:
    """A kind of terrain: the name ``KIND-N1-...-Nk`` builds ``build(N1, ..., Nk)``.

    ``grammar`` are its numbers (:class:`Field`), in the name's order. A kind with ``sample``
    also names a distribution, ``KIND-N1-...-rnd``: its last number is drawn afresh,
    ``sample(rng, n)`` giving ``n`` values of it."""

    grammar: tuple[Field, ...]
    build: Callable[..., Terrain]
    sample: Callable[[np.random.Generator, int], list] | None = None


def _training_seeds(rng: np.random.Generator, n: int) -> list[int]:
    return [int(s) for s in rng.integers(0, N_TRAINING_SEEDS, n)]


def _slopes(rng: np.random.Generator, n: int) -> list[float]:
    steps = rng.integers(0, int(MAX_SLOPE_DEG / SLOPE_STEP_DEG) + 1, n)
    return [SLOPE_STEP_DEG * int(k) for k in steps]


H = Field("H", f"0 <= H <= {MAX_SIZE:g} m",
          ((lambda h: h <= MAX_SIZE, f"the height H must be at most {MAX_SIZE:g} m"),), 1.0)
W = Field("W", f"0 < W <= {MAX_SIZE:g} m",
          ((lambda w: w > 0, "the step width W must be positive"),
           (lambda w: w <= MAX_SIZE, f"the step width W must be at most {MAX_SIZE:g} m")), 10.0)
SEED = Field("SEED", "0 <= SEED < 2**63",
             ((lambda s: s < MAX_SEED, "SEED must be below 2**63 (a Java long)"),), 42,
             whole=True)
DEG = Field("DEG", f"0 <= DEG < {MAX_SLOPE:g} degrees",
            ((lambda d: d < MAX_SLOPE, f"slopes must be under {MAX_SLOPE:g} degrees (DEG)"),),
            5.0)

TERRAIN_KINDS: dict[str, TerrainKind] = {
    "flat": TerrainKind((), flat),
    "hilly": TerrainKind((H, W, SEED), hilly, _training_seeds),
    "steppy": TerrainKind((H, W, SEED), steppy, _training_seeds),
    "uphill": TerrainKind((DEG,), lambda d: slope(d, f"uphill-{_fmt(d)}"), _slopes),
    "downhill": TerrainKind((DEG,), lambda d: slope(-d, f"downhill-{_fmt(d)}"), _slopes),
}
"""Every kind of terrain, by the word its names start with: the one table that the parsers,
the help texts and the tests read. A new kind is an entry here (and its builder)."""


def _or(words: list[str]) -> str:
    return ", ".join(words[:-1]) + f" or {words[-1]}" if len(words) > 1 else words[0]


def _help() -> tuple[str, str]:
    bounds = dict.fromkeys(f.bounds for kind in TERRAIN_KINDS.values() for f in kind.grammar)
    fixed = _or(["-".join([name, *(f.letter for f in kind.grammar)])
                 for name, kind in TERRAIN_KINDS.items()])
    fixed += (f" ({', '.join(bounds)}; each number written as the shortest decimal: 1 "
              "not 1.0, 10000 not 010000)")
    drawn = ", ".join("-".join([name, *(f.letter for f in kind.grammar[:-1]), RANDOM])
                      for name, kind in TERRAIN_KINDS.items() if kind.sample is not None)
    return fixed, f"{drawn}, or one fixed terrain: {fixed}"


TERRAIN_HELP, DISTRIBUTION_HELP = _help()
"""What a terrain name (``--terrain`` of simulate, show) and a training distribution
(``--terrain`` of evolve) may be, written from :data:`TERRAIN_KINDS`."""

_NUMBER = {False: r"([0-9]+(?:\.[0-9]+)?)", True: r"([0-9]+)"}


def _pattern(name: str, fields: tuple[Field, ...], tail: tuple[str, ...] = ()) -> re.Pattern:
    return re.compile("^" + "-".join([re.escape(name), *(_NUMBER[f.whole] for f in fields),
                                      *tail]) + "$")


_FIXED = {name: _pattern(name, kind.grammar) for name, kind in TERRAIN_KINDS.items()}
_DRAWN = {name: _pattern(name, kind.grammar[:-1], (RANDOM,)) for name, kind in TERRAIN_KINDS.items()
          if kind.sample is not None}


def _numbers(text: str, fields: tuple[Field, ...], parts: tuple[str, ...]) -> tuple[list, list]:
    """The values of the numbers ``parts`` of the name ``text`` and their one spelling each;
    a one-line error naming the field of one too long (over :data:`MAX_NUMBER_CHARS`
    characters) or out of its bounds."""
    values, spelled = [], []
    for field, part in zip(fields, parts):
        if len(part) > MAX_NUMBER_CHARS:
            raise bad("terrain", text, f"{field.letter} has more than {MAX_NUMBER_CHARS} "
                      "characters")
        value = int(part) if field.whole else float(part)
        for test, why in field.checks:
            if not test(value):
                raise bad("terrain", text, why)
        values.append(value)
        spelled.append(str(value) if field.whole else _fmt(value))
    return values, spelled


def _canonical(text: str, name: str, spelled: list[str]) -> None:
    """Refuse ``name`` (read from ``text``) unless it is ``spelled`` joined, the one spelling
    of its terrain: ``terrain='hilly-1.0-10-5': write it hilly-1-10-5``."""
    one = "-".join(spelled)
    if name != one:
        raise bad("terrain", text, f"write it {one}")


def parse_name(text: str, drawn: bool = False) -> tuple[str, tuple]:
    """The kind and the numbers of the terrain name ``text`` (the grammar is in the module's
    docstring), or with ``drawn`` of the distribution name ``KIND-...-rnd`` (its numbers but
    the drawn one); a one-line error for anything else, naming the one spelling of a name
    spelled another way."""
    name = str(text).strip()
    for kind, pattern in (_DRAWN if drawn else _FIXED).items():
        match = pattern.match(name)
        if match:
            fields = TERRAIN_KINDS[kind].grammar
            values, spelled = _numbers(text, fields[:-1] if drawn else fields, match.groups())
            _canonical(text, name, [kind, *spelled, *([RANDOM] if drawn else [])])
            return kind, tuple(values)
    if drawn:
        raise bad("terrain", text, f"unknown terrain distribution; use {DISTRIBUTION_HELP}")
    raise bad("terrain", text, f"unknown terrain; use {TERRAIN_HELP}")


def parse_terrain(text: str) -> Terrain:
    """Build a terrain from its name (the grammar is in the module's docstring); raises a
    one-line error for anything else, naming the one spelling of a terrain spelled
    another way."""
    kind, values = parse_name(text)
    return TERRAIN_KINDS[kind].build(*values)


@functools.lru_cache(maxsize=16384)
def drawn_terrain(kind: str, values: tuple) -> Terrain:
    """The terrain of kind ``kind`` with the numbers ``values``, built once: a training run
    draws from a few thousand terrains many times over, and building one is not free."""
    return TERRAIN_KINDS[kind].build(*values)
