"""The analytic terrain height h(x, y) and the grid that approximates it (numpy only).

A `Heightfield` is a pure function of (x, y): seeded fractal gradient noise plus zone
features (hills, flattened plateaus, a lake basin, a cave pit), each a smooth (C2) term, so
it gives the same numbers for the same seed anywhere, at any density.

The terrain mesh is a `TerrainGrid`: a rectilinear grid whose column and row spacings are
chosen against the height error the triangulated grid makes versus the analytic field
(`fit_grid`): lines are closer where the field curves more (hill tops, the cave's walls),
so no triangle is spent on detail the sensor could not see.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from .. import detmath as dm
from .grid_height import interpolate
from .shapes.primitives import grid_heightfield

Field = Callable[[np.ndarray, np.ndarray], np.ndarray]


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


def lattice(extent: Sequence[float], spacing: float) -> tuple[np.ndarray, np.ndarray]:
    xmin, xmax, ymin, ymax = extent
    nx = int(math.ceil((xmax - xmin) / spacing)) + 1
    ny = int(math.ceil((ymax - ymin) / spacing)) + 1
    return np.linspace(xmin, xmax, nx), np.linspace(ymin, ymax, ny)


# ---------------------------------------------------------------------------------------
# the grid


@dataclass
class TerrainGrid:
    """Heights z[j, i] at (xs[i], ys[j]); each cell split along its (i,j)-(i+1,j+1) diagonal,
    the triangulation `shapes.primitives.grid_heightfield` builds."""

    xs: np.ndarray
    ys: np.ndarray
    z: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.ys), len(self.xs)

    @property
    def vertex_count(self) -> int:
        return len(self.xs) * len(self.ys)

    @property
    def triangle_count(self) -> int:
        return 2 * (len(self.xs) - 1) * (len(self.ys) - 1)

    def height_at(self, x, y):
        """The triangulated grid's height (what a vertical ray hits), anywhere inside it."""
        return interpolate(self.xs, self.ys, self.z, x, y)

    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        return grid_heightfield(self.xs, self.ys, self.z)


def sample_grid(field_fn: Field, xs, ys) -> TerrainGrid:
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.asarray(ys, dtype=np.float64)
    gx, gy = np.meshgrid(xs, ys)
    return TerrainGrid(xs, ys, field_fn(gx, gy))


def uniform_grid(field_fn: Field, extent: Sequence[float], spacing: float) -> TerrainGrid:
    return sample_grid(field_fn, *lattice(extent, spacing))


@dataclass(frozen=True)
class GridError:
    """How far the triangulated grid is from the analytic field, metres."""

    max: float
    rms: float
    p99: float
    samples: int

    def to_dict(self) -> dict:
        return {"max": self.max, "rms": self.rms, "p99": self.p99, "samples": self.samples}


def error_sample_points(extent: Sequence[float], count: int, rng: np.random.Generator) -> np.ndarray:
    xmin, xmax, ymin, ymax = extent
    return np.column_stack([rng.uniform(xmin, xmax, count), rng.uniform(ymin, ymax, count)])


def grid_error(field_fn: Field, grid: TerrainGrid, points: np.ndarray) -> GridError:
    """Error of the grid against the field at the given (N, 2) points."""
    err = np.abs(grid.height_at(points[:, 0], points[:, 1]) - field_fn(points[:, 0], points[:, 1]))
    return GridError(
        max=float(err.max()),
        rms=float(np.sqrt(np.mean(err**2))),
        p99=float(np.quantile(err, 0.99)),
        samples=len(err),
    )


def curvature_profiles(field_fn: Field, extent: Sequence[float], probe: float = 0.5):
    """Per probe column, the largest |h_xx| + |h_xy| over y; per row, |h_yy| + |h_xy| over x.

    Linear interpolation over a cell of size s errs by about s^2/8 times the
    second derivative across it, so these profiles say how close grid lines
    must be at each x and each y.
    """
    xs, ys = lattice(extent, probe)
    gx, gy = np.meshgrid(xs, ys)
    z = field_fn(gx, gy)
    zxx = np.zeros_like(z)
    zyy = np.zeros_like(z)
    zxx[:, 1:-1] = (z[:, 2:] - 2 * z[:, 1:-1] + z[:, :-2]) / (probe * probe)
    zyy[1:-1, :] = (z[2:, :] - 2 * z[1:-1, :] + z[:-2, :]) / (probe * probe)
    zxy = np.zeros_like(z)
    zxy[1:-1, 1:-1] = (z[2:, 2:] - z[2:, :-2] - z[:-2, 2:] + z[:-2, :-2]) / (4 * (probe * probe))
    cx = (np.abs(zxx) + np.abs(zxy)).max(axis=0)
    cy = (np.abs(zyy) + np.abs(zxy)).max(axis=1)
    # a line must also suit its neighbours' curvature (the probe is coarse)
    cx = np.maximum.reduce([cx, np.roll(cx, 1), np.roll(cx, -1)])
    cy = np.maximum.reduce([cy, np.roll(cy, 1), np.roll(cy, -1)])
    return xs, cx, ys, cy


def adaptive_axis(
    start: float,
    stop: float,
    probe_pos: np.ndarray,
    curvature: np.ndarray,
    tol: float,
    factor: float,
    s_min: float,
    s_max: float,
) -> np.ndarray:
    """Grid line positions from start to stop whose local spacing keeps s^2/8 * curvature
    under tol (times `factor`, the correction `fit_grid` measures)."""
    spacing = np.clip(factor * np.sqrt(8.0 * tol / np.maximum(curvature, 1e-12)), s_min, s_max)
    out = [start]
    x = start
    while stop - x > 1e-9:
        step = s_max
        for _ in range(3):  # shrink until the step suits every probe it spans
            lo = max(np.searchsorted(probe_pos, x, side="right") - 1, 0)
            hi = np.searchsorted(probe_pos, x + step, side="left") + 1
            step = min(step, float(spacing[lo:hi].min()))
        left = stop - x
        if left <= step * 1.0001:
            x = stop
        elif left < 2.0 * step:  # split the rest evenly rather than leave a sliver
            x += left / 2.0
        else:
            x += step
        out.append(x)
    return np.asarray(out, dtype=np.float64)


@dataclass
class GridFit:
    grid: TerrainGrid
    error: GridError
    tolerance: float
    iterations: int
    spacing_min: float
    spacing_max: float


FIT_MARGIN = 0.75


def fit_grid(
    field_fn: Field,
    extent: Sequence[float],
    tol: float,
    rng: np.random.Generator,
    s_min: float = 0.1,
    s_max: float = 8.0,
    samples: int = 100_000,
    probe: float = 0.5,
) -> GridFit:
    """The coarsest adaptive rectilinear grid whose measured max error is within `tol`.

    Spacing comes from the curvature estimate; the error is then measured at
    random points against the analytic field, and all spacings shrink until the
    measurement agrees (rarely more than one extra round). Random points miss
    the true worst spot between them (a denser sample finds a larger max),
    so the sampled max must stay within FIT_MARGIN of `tol`.
    """
    px, cx, py, cy = curvature_profiles(field_fn, extent, probe)
    points = error_sample_points(extent, samples, rng)
    truth = field_fn(points[:, 0], points[:, 1])
    factor = 1.0
    iteration = 0
    for iteration in range(1, 8):  # noqa: B007 (reported in GridFit)
        xs = adaptive_axis(extent[0], extent[1], px, cx, tol, factor, s_min, s_max)
        ys = adaptive_axis(extent[2], extent[3], py, cy, tol, factor, s_min, s_max)
        grid = sample_grid(field_fn, xs, ys)
        err = np.abs(grid.height_at(points[:, 0], points[:, 1]) - truth)
        worst = float(err.max())
        if worst <= FIT_MARGIN * tol or min(np.diff(xs).min(), np.diff(ys).min()) <= s_min * 1.001:
            break
        factor *= 0.9 * math.sqrt(FIT_MARGIN * tol / worst)
    error = GridError(
        float(err.max()), float(np.sqrt(np.mean(err**2))), float(np.quantile(err, 0.99)), len(err)
    )
    steps = np.concatenate([np.diff(xs), np.diff(ys)])
    return GridFit(grid, error, tol, iteration, float(steps.min()), float(steps.max()))
