"""The analytic terrain height h(x, y) and the grid that approximates it (numpy only).

A `Heightfield` is a pure function of (x, y): seeded fractal gradient noise plus zone
features (hills, flattened plateaus, a lake basin, a cave pit), each a smooth (C2) term, so
it gives the same numbers for the same seed anywhere, at any density.

The terrain mesh that approximates it is terrain_grid.py's `TerrainGrid` (`fit_grid`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .. import detmath as dm
from .terrain_grid import lattice

# ---------------------------------------------------------------------------------------
# smooth building blocks


def smootherstep(t):
    """0 below 0, 1 above 1, C2 in between (Perlin's 6t^5 - 15t^4 + 10t^3)."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


class GradientNoise:
    """2D Perlin gradient noise with a seeded permutation and gradient set.

    Values lie in about [-1, 1]; the quintic fade makes it C2, so the grid
    error estimate from second derivatives holds.
    """

    def __init__(self, rng: np.random.Generator):
        perm = rng.permutation(256)
        self.perm = np.concatenate([perm, perm]).astype(np.int64)
        angles = rng.uniform(0.0, 2.0 * np.pi, 256)
        self.gy, self.gx = dm.sincos(angles)

    def _corner(self, i, j, dx, dy):
        g = self.perm.take(self.perm.take(i) + j)  # take: the same gathers, faster than indexing
        return self.gx.take(g) * dx + self.gy.take(g) * dy

    def __call__(self, x, y):
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        x0, y0 = np.floor(x), np.floor(y)
        fx, fy = x - x0, y - y0
        i = x0.astype(np.int64) & 255
        j = y0.astype(np.int64) & 255
        i1, j1 = (i + 1) & 255, (j + 1) & 255
        n00 = self._corner(i, j, fx, fy)
        n10 = self._corner(i1, j, fx - 1.0, fy)
        n01 = self._corner(i, j1, fx, fy - 1.0)
        n11 = self._corner(i1, j1, fx - 1.0, fy - 1.0)
        u, v = smootherstep(fx), smootherstep(fy)
        a = n00 + u * (n10 - n00)
        b = n01 + u * (n11 - n01)
        return math.sqrt(2.0) * (a + v * (b - a))


class FractalNoise:
    """Sum of octaves of gradient noise (fBm), normalised so its values lie in about [-1, 1].

    `wavelength` is the largest feature in metres; each octave halves it. The
    finest octave sets how fine the terrain grid must be, so octaves stop at a
    few metres: smaller bumps are grass and rocks, modelled as elements.
    """

    def __init__(self, rng: np.random.Generator, wavelength: float, octaves: int, gain: float = 0.5):
        self.wavelength = float(wavelength)
        self.octaves = int(octaves)
        self.gain = float(gain)
        self.layers = [GradientNoise(rng) for _ in range(self.octaves)]
        self.shifts = rng.uniform(0.0, 256.0, (self.octaves, 2))
        amps = np.cumprod(np.concatenate([[1.0], np.full(self.octaves - 1, self.gain)]))  # gain^k
        self.amps = amps / amps.sum()

    def __call__(self, x, y):
        out = np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)
        for k, (noise, shift, amp) in enumerate(zip(self.layers, self.shifts, self.amps)):
            f = math.ldexp(1.0, k) / self.wavelength
            out = out + amp * noise(np.asarray(x) * f + shift[0], np.asarray(y) * f + shift[1])
        return out


# ---------------------------------------------------------------------------------------
# windows: where a feature applies (1 inside, 0 outside, C2 ramp between)


@dataclass(frozen=True)
class RectWindow:
    """1 deeper than `blend` inside the rectangle, 0 on and outside its edges."""

    xmin: float
    xmax: float
    ymin: float
    ymax: float
    blend: float

    def __call__(self, x, y):
        b = self.blend
        return (
            smootherstep((np.asarray(x) - self.xmin) / b)
            * smootherstep((self.xmax - np.asarray(x)) / b)
            * smootherstep((np.asarray(y) - self.ymin) / b)
            * smootherstep((self.ymax - np.asarray(y)) / b)
        )


@dataclass(frozen=True)
class Ellipse:
    """A rotated ellipse; `radius` is the normalised distance (1 on the outline)."""

    cx: float
    cy: float
    a: float  # semi-axis along `angle`
    b: float  # semi-axis across
    angle: float  # radians

    def local(self, x, y):
        """Coordinates along and across the ellipse's axis, metres."""
        dx, dy = np.asarray(x) - self.cx, np.asarray(y) - self.cy
        s, c = dm.sincos(self.angle)
        return c * dx + s * dy, -s * dx + c * dy

    def to_world(self, u, v):
        s, c = dm.sincos(self.angle)
        return self.cx + c * np.asarray(u) - s * np.asarray(v), self.cy + s * np.asarray(u) + c * np.asarray(
            v
        )

    def radius(self, x, y):
        u, v = self.local(x, y)
        # sqrt smoothed at the centre (eps) keeps the field C2 there
        ua, vb = u / self.a, v / self.b
        return np.sqrt(ua * ua + vb * vb + 1e-6)


@dataclass(frozen=True)
class EllipseWindow:
    """1 inside normalised radius r_in, 0 beyond r_out."""

    ellipse: Ellipse
    r_in: float
    r_out: float

    def __call__(self, x, y):
        r = self.ellipse.radius(x, y)
        return 1.0 - smootherstep((r - self.r_in) / (self.r_out - self.r_in))


# ---------------------------------------------------------------------------------------
# features: each maps (x, y, h) -> h


@dataclass(frozen=True)
class Bumps:
    """Gaussian hills, faded out by `window` so they stay inside their zone."""

    centres: tuple[tuple[float, float], ...]
    heights: tuple[float, ...]
    sigmas: tuple[float, ...]
    window: RectWindow
    gain: float = 1.0  # lowered by the planner when the hills would exceed the world's relief

    def apply(self, x, y, h):
        add = 0.0
        for (cx, cy), a, s in zip(self.centres, self.heights, self.sigmas):
            dx, dy = np.asarray(x) - cx, np.asarray(y) - cy
            add = add + a * dm.exp(-(dx * dx + dy * dy) / (2.0 * s * s))
        return h + self.gain * add * self.window(x, y)


@dataclass(frozen=True)
class Flatten:
    """Pull the height towards `level` where the window is 1 (strength < 1 keeps some relief)."""

    window: object
    level: float
    strength: float = 1.0

    def apply(self, x, y, h):
        return h + (self.level - h) * (self.strength * self.window(x, y))


@dataclass(frozen=True)
class Basin:
    """A bowl: `depth` below the surroundings inside r_floor, rising smoothly to 0 at r_rim."""

    ellipse: Ellipse
    depth: float
    r_floor: float
    r_rim: float

    def carve(self, x, y):
        r = self.ellipse.radius(x, y)
        return 1.0 - smootherstep((r - self.r_floor) / (self.r_rim - self.r_floor))

    def apply(self, x, y, h):
        return h - self.depth * self.carve(x, y)


@dataclass(frozen=True)
class Pit:
    """The cave: a flat-floored pit with a ramp climbing out along +axis.

    The pit and ramp depths (each 0..1) join as 1 - (1-p)(1-q), a smooth union,
    so the terrain stays one continuous C2 surface: no hole, no crack.
    """

    ellipse: Ellipse
    depth: float
    r_floor: float  # normalised radius where the walls start
    ramp_length: float  # metres beyond the pit end where the ramp reaches the surface
    ramp_half_width: float  # metres, flat part of the ramp
    ramp_blend: float  # metres, side slopes of the ramp

    def ramp(self, x, y):
        u, v = self.ellipse.local(x, y)
        along = 1.0 - smootherstep(
            (u - self.ellipse.a * self.r_floor) / (self.ellipse.a * (1 - self.r_floor) + self.ramp_length)
        )
        inside = smootherstep(4.0 * u / self.ellipse.a)  # the ramp only on the +axis half
        across = 1.0 - smootherstep((np.abs(v) - self.ramp_half_width) / self.ramp_blend)
        return along * inside * across

    def carve(self, x, y):
        r = self.ellipse.radius(x, y)
        p = 1.0 - smootherstep((r - self.r_floor) / (1.0 - self.r_floor))
        q = self.ramp(x, y)
        return 1.0 - (1.0 - p) * (1.0 - q)

    def apply(self, x, y, h):
        return h - self.depth * self.carve(x, y)


# ---------------------------------------------------------------------------------------
# the field


@dataclass
class Heightfield:
    """h(x, y) = scale * (amplitude * noise + features... - offset)."""

    noise: FractalNoise
    amplitude: float
    features: list = field(default_factory=list)
    offset: float = 0.0
    scale: float = 1.0

    # the last lattice's noise, by the bytes of its x and y: the planner evaluates the field on
    # one lattice again and again (the relief, while it lowers the hills), and only the
    # features change between those calls
    _noise_memo: tuple = field(default=(), repr=False, compare=False)

    def raw(self, x, y):
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        h = self.amplitude * self._noise_at(x, y)
        for feature in self.features:
            h = feature.apply(x, y, h)
        return h

    def __call__(self, x, y):
        return self.scale * (self.raw(x, y) - self.offset)

    def _noise_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """self.noise(x, y), kept for the next call on the same points (the same values)."""
        if x.size < 1024:  # elements' single points: not worth the comparison
            return self.noise(x, y)
        key = (id(self.noise), x.shape, y.shape, x.tobytes(), y.tobytes())
        if self._noise_memo and self._noise_memo[0] == key:
            return self._noise_memo[1]
        values = self.noise(x, y)
        values.flags.writeable = False  # shared by the calls that read it
        self._noise_memo = (key, values)
        return values

    def mean_over(self, window, extent: Sequence[float], spacing: float = 1.0) -> float:
        """Window-weighted mean height (what a plateau is flattened to)."""
        xs, ys = lattice(extent, spacing)
        gx, gy = np.meshgrid(xs, ys)
        w = window(gx, gy)
        return float((self(gx, gy) * w).sum() / max(w.sum(), 1e-9))

    def relief(self, extent: Sequence[float], spacing: float = 1.0) -> float:
        xs, ys = lattice(extent, spacing)
        z = self(*np.meshgrid(xs, ys))
        return float(z.max() - z.min())

    def normalise(self, extent: Sequence[float], max_relief: float, spacing: float = 0.5) -> None:
        """Lowest point at 0 and relief at most `max_relief` (a constant shift and scale, so
        the field stays analytic and smooth)."""
        xs, ys = lattice(extent, spacing)
        z = self.raw(*np.meshgrid(xs, ys))
        lo, hi = float(z.min()), float(z.max())
        self.offset = lo
        self.scale = min(1.0, max_relief / max(hi - lo, 1e-9))
