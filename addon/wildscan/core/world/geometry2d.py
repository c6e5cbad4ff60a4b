"""Plane geometry the stages share: polylines, rectangles, headings, scattered points (numpy only)."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from .. import detmath as dm

Rect = tuple[float, float, float, float]  # xmin, xmax, ymin, ymax


# ---------------------------------------------------------------------------------------
# polylines


def polyline_length(path: np.ndarray) -> float:
    step = np.diff(path, axis=0)
    return float(dm.hypot(step[:, 0], step[:, 1]).sum())


def polyline_distance(path: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance from each point (N,2) to the polyline (K,2)."""
    a, b = path[:-1], path[1:]
    ab = b - a
    L2 = np.maximum(ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1], 1e-12)
    best = np.full(len(pts), np.inf)
    for start in range(0, len(a), 256):  # chunks keep memory small
        aa, dd, ll = a[start : start + 256], ab[start : start + 256], L2[start : start + 256]
        rel = pts[:, None, :] - aa[None]
        t = np.clip((rel[..., 0] * dd[None, :, 0] + rel[..., 1] * dd[None, :, 1]) / ll[None], 0, 1)
        gap = pts[:, None, :] - (aa[None] + t[..., None] * dd[None])
        best = np.minimum(best, dm.hypot(gap[..., 0], gap[..., 1]).min(1))
    return best


def polyline_frame(path: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per point (N,2), the polyline's (K,2) nearest segment's frame: the point's signed
    offset from that segment's line (positive to its left) and the segment's unit tangent
    (N,2). A point's nearest segment is the first of the least distance."""
    a, ab = path[:-1], np.diff(path, axis=0)
    length = dm.hypot(ab[:, 0], ab[:, 1])
    L2 = np.maximum(ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1], 1e-12)
    rel = pts[:, None, :] - a[None]
    t = np.clip((rel[..., 0] * ab[None, :, 0] + rel[..., 1] * ab[None, :, 1]) / L2[None], 0, 1)
    gap = rel - t[..., None] * ab[None]
    nearest = np.argmin(gap[..., 0] * gap[..., 0] + gap[..., 1] * gap[..., 1], axis=1)
    tangent = ab[nearest] / np.maximum(length[nearest], 1e-12)[:, None]
    r = pts - a[nearest]
    return tangent[:, 0] * r[:, 1] - tangent[:, 1] * r[:, 0], tangent


def polyline_near(path: np.ndarray, pts: np.ndarray, limit: float) -> np.ndarray:
    """polyline_distance(path, pts) < limit, the distance computed only for the points in the
    path's bounding box grown by limit + 1 m: one farther out is farther than limit + 1 m
    from every segment, far beyond any rounding, and each point's distance is the same
    computation with or without the others (a scatter's candidates, mostly in other zones,
    took a quarter of a world's plan)."""
    grow = limit + 1.0
    low, high = path.min(axis=0) - grow, path.max(axis=0) + grow
    maybe = np.flatnonzero(
        (pts[:, 0] >= low[0]) & (pts[:, 0] <= high[0]) & (pts[:, 1] >= low[1]) & (pts[:, 1] <= high[1])
    )
    near = np.zeros(len(pts), dtype=bool)
    if len(maybe):
        near[maybe] = polyline_distance(path, pts[maybe]) < limit
    return near


def catmull_rom(ctrl: np.ndarray, step: float) -> np.ndarray:
    """A smooth curve through control points, resampled every `step` metres."""
    p = np.vstack([2 * ctrl[0] - ctrl[1], ctrl, 2 * ctrl[-1] - ctrl[-2]])
    pts = []
    for i in range(1, len(p) - 2):
        t = np.linspace(0, 1, 40, endpoint=False)[:, None]
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        pts.append(
            0.5
            * (
                (2 * p1)
                + (-p0 + p2) * t
                + (2 * p0 - 5 * p1 + 4 * p2 - p3) * (t * t)
                + (-p0 + 3 * p1 - 3 * p2 + p3) * (t * t * t)
            )
        )
    pts.append(ctrl[-1:])
    dense = np.vstack(pts)
    return resample(dense, step)


def resample(path: np.ndarray, step: float) -> np.ndarray:
    """A polyline (K, 2) resampled at equal steps of about `step` metres along it."""
    diff = np.diff(path, axis=0)
    seg = dm.hypot(diff[:, 0], diff[:, 1])
    s = np.concatenate([[0], np.cumsum(seg)])
    n = max(2, int(math.ceil(s[-1] / step)) + 1)
    t = np.linspace(0, s[-1], n)
    return np.column_stack([dm.interp(t, s, path[:, k]) for k in range(path.shape[1])])


# ---------------------------------------------------------------------------------------
# rectangles and headings


def float_range(start: float, stop: float, step: float) -> np.ndarray:
    """np.arange(start, stop, step) as numpy fills it (start + i * ((start + step) - start)),
    but in separate ufuncs: numpy's C loop may be fused into FMAs by an arm64 compiler."""
    count = max(int(math.ceil((stop - start) / step)), 0)
    return start + np.arange(count) * ((start + step) - start)


def cell_area(rect: Rect) -> float:
    return (rect[1] - rect[0]) * (rect[3] - rect[2])


def inset(rect: Rect, d: float) -> Rect:
    return (rect[0] + d, rect[1] - d, rect[2] + d, rect[3] - d)


def long_axis(rect: Rect) -> int:
    """0 when the cell is wider along X, 1 along Y."""
    return 0 if rect[1] - rect[0] >= rect[3] - rect[2] else 1


def yaw_towards(x, y, tx, ty) -> float:
    """Heading in degrees (0-360, CCW from +X, 0.1 deg steps) from (x, y) to (tx, ty)."""
    return round(dm.degrees(dm.arctan2(ty - y, tx - x)) % 360.0, 1)


# ---------------------------------------------------------------------------------------
# scattering


def darts(
    rng: np.random.Generator, rect: Rect, count: int, min_dist: float, ok: Callable, tries: int = 6
) -> np.ndarray:
    """Up to `count` points in `rect`, at least `min_dist` apart, where ok(x, y) holds
    (rejection sampling in batches; deterministic for a given generator)."""
    x0, x1, y0, y1 = rect
    cand = np.column_stack([rng.uniform(x0, x1, count * tries), rng.uniform(y0, y1, count * tries)])
    cand = cand[ok(cand[:, 0], cand[:, 1])]
    cell = max(min_dist, 1e-6)
    taken: dict[tuple[int, int], list] = {}
    out = []
    for x, y in cand:
        if len(out) >= count:
            break
        ix, iy = int(x // cell), int(y // cell)
        near = [p for dx in (-1, 0, 1) for dy in (-1, 0, 1) for p in taken.get((ix + dx, iy + dy), ())]
        if any((x - px) * (x - px) + (y - py) * (y - py) < min_dist * min_dist for px, py in near):
            continue
        taken.setdefault((ix, iy), []).append((x, y))
        out.append((x, y))
    return np.array(out, dtype=np.float64).reshape(-1, 2)
