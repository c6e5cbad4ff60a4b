"""The height of a triangulated terrain grid at points (numpy only): what a vertical ray
hits, the ground elements stand on. Its own module for the one-point path a world's
elements ask ~5,000 times."""

from __future__ import annotations

import math

import numpy as np


def interpolate(xs, ys, z, x, y):
    """The triangulated grid's height: z00 + tx (z10 - z00) + ty (z11 - z10) in a cell's lower
    triangle, z00 + ty (z01 - z00) + tx (z11 - z01) in its upper one; as z00 + a (m - z00) +
    b (z11 - m) with (a, b, m) chosen per point: one evaluation a point, the same bits."""
    if _one_finite_point(x, y) and len(xs) > 1 and len(ys) > 1:
        return np.asarray(_interpolate_point(xs, ys, z, float(x), float(y)))
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    shape, x, y, nx = x.shape, x.ravel(), y.ravel(), len(xs)
    i, j = cell_index(xs, x), cell_index(ys, y)
    tx = np.clip((x - xs.take(i)) / np.diff(xs).take(i), 0.0, 1.0)
    ty = np.clip((y - ys.take(j)) / np.diff(ys).take(j), 0.0, 1.0)
    flat, corner, lower = np.ravel(z), j * nx + i, tx >= ty  # lower: triangle (00, 10, 11)
    z00, z11 = flat.take(corner), flat.take(corner + (nx + 1))
    middle = flat.take(np.where(lower, corner + 1, corner + nx))  # z10 below the diagonal, z01 above
    return (
        z00 + np.where(lower, tx, ty) * (middle - z00) + np.where(lower, ty, tx) * (z11 - middle)
    ).reshape(shape)


def cell_index(nodes: np.ndarray, v: np.ndarray) -> np.ndarray:
    """clip(searchsorted(nodes, v, "right") - 1, 0, len(nodes) - 2), the cell of each v along
    a sorted grid axis, exactly; for many points, from a table of buckets a third of the
    closest nodes' spacing wide (a searchsorted of 100k values is a binary search each).
    A value's bucket, computed in floats, is its own or a neighbour (a rounding at an edge);
    the last node at or before that bucket's start is then at most one node off, above
    (a bucket one too high) or below (one too low: fewer than two buckets lie between that
    start and v, less than the closest spacing, so no two nodes), and one step each way
    reaches the searchsorted answer. NaN: the last cell, as searchsorted gives."""
    n = len(nodes)
    spacing = float(np.min(np.diff(nodes))) if n > 1 else 0.0
    if n < 2 or len(v) < _TABLE_MIN or not spacing > 0:
        return np.clip(np.searchsorted(nodes, v, side="right") - 1, 0, max(n - 2, 0))
    width, start = spacing / 3, float(nodes[0])
    count = int(np.ceil((float(nodes[-1]) - start) / width)) + 1
    if count > len(v):  # nodes far closer somewhere than elsewhere: a table larger than the search
        return np.clip(np.searchsorted(nodes, v, side="right") - 1, 0, n - 2)
    before = np.searchsorted(nodes, start + width * np.arange(count), side="right") - 1
    bucket = np.fmax(np.fmin((v - start) * (1.0 / width), count - 1), 0.0).astype(np.intp)
    i = before.take(bucket)  # >= 0: the first bucket starts at the first node
    i -= nodes.take(i) > v  # a node above v: one down (to -1 below the first node)
    i += nodes.take(np.minimum(i + 1, n - 1)) <= v  # the next node at or below v: one up
    return np.clip(i, 0, n - 2, out=i)


_TABLE_MIN = 256  # values: fewer are searched directly


def _one_finite_point(x, y) -> bool:
    """Whether (x, y) is one point of finite floats (Python, numpy or 0-d arrays)."""
    return _one_float(x) and _one_float(y) and math.isfinite(float(x) + float(y))


def _one_float(v) -> bool:
    if isinstance(v, np.ndarray):
        return v.ndim == 0 and v.dtype.kind == "f"
    return isinstance(v, (float, np.floating))


def _interpolate_point(xs, ys, z, x: float, y: float) -> float:
    """interpolate() at one point, in Python floats: the same IEEE operations in the same
    order (numpy's elementwise steps use no fused multiply-add either), without the ~50 us of
    numpy calls an array of one point costs; a world's elements ask it ~5,000 times."""
    i = min(max(int(xs.searchsorted(x, side="right")) - 1, 0), len(xs) - 2)
    j = min(max(int(ys.searchsorted(y, side="right")) - 1, 0), len(ys) - 2)
    x0, y0 = float(xs[i]), float(ys[j])
    tx = min(max((x - x0) / (float(xs[i + 1]) - x0), 0.0), 1.0)
    ty = min(max((y - y0) / (float(ys[j + 1]) - y0), 0.0), 1.0)
    corner, nx = j * len(xs) + i, len(xs)  # z's flat index, as interpolate() takes it
    z00, z11 = float(z.item(corner)), float(z.item(corner + nx + 1))
    if tx >= ty:  # the lower triangle (00, 10, 11)
        middle = float(z.item(corner + 1))
        return z00 + tx * (middle - z00) + ty * (z11 - middle)
    middle = float(z.item(corner + nx))
    return z00 + ty * (middle - z00) + tx * (z11 - middle)
