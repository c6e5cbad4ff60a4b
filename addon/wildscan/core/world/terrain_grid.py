"""The grid that approximates the terrain's height field (numpy only).

The terrain mesh is a `TerrainGrid`: a rectilinear grid whose column and row spacings are
chosen against the height error the triangulated grid makes versus the analytic field
(heightfield.py, `fit_grid`): lines are closer where the field curves more (hill tops, the
cave's walls), so no triangle is spent on detail the sensor could not see.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from .grid_height import interpolate
from .shapes.primitives import grid_heightfield

Field = Callable[[np.ndarray, np.ndarray], np.ndarray]


def lattice(extent: Sequence[float], spacing: float) -> tuple[np.ndarray, np.ndarray]:
    xmin, xmax, ymin, ymax = extent
    nx = int(math.ceil((xmax - xmin) / spacing)) + 1
    ny = int(math.ceil((ymax - ymin) / spacing)) + 1
    return np.linspace(xmin, xmax, nx), np.linspace(ymin, ymax, ny)


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
