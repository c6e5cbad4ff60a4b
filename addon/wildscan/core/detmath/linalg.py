"""3-vectors and 3x3 matrices summed in the written order (instead of einsum, dot, matmul
and BLAS, whose order and FMA use depend on the machine), and numpy's interp as separate
ufuncs."""

from __future__ import annotations

import numpy as np

from ._core import ERRSTATE, as_array, unwrap


def dot3(a, b):
    """a . b over the last axis (length 3): (a0 b0 + a1 b1) + a2 b2."""
    a, b = as_array(a), as_array(b)
    return unwrap(a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2])


def cross(a, b):
    """a x b over the last axis (length 3); the same products and differences as np.cross."""
    a, b = as_array(a), as_array(b)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def norm(a):
    """Euclidean length over the last axis (length 3)."""
    return unwrap(np.sqrt(dot3(a, a)))


def apply(matrix, vectors) -> np.ndarray:
    """matrix . v for every vector v along the last axis (= vectors @ matrix.T), each
    component ((m_i0 v0 + m_i1 v1) + m_i2 v2); the matrix may be batched (..., 3, 3)."""
    m, v = as_array(matrix), as_array(vectors)
    if m.ndim == 2 and v.ndim >= 2:
        return _apply_by_columns(m, v)
    out = v[..., None, 0] * m[..., :, 0]
    out += v[..., None, 1] * m[..., :, 1]
    out += v[..., None, 2] * m[..., :, 2]
    return out


def _apply_by_columns(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """apply() of one matrix to many vectors, the same products and sums on contiguous
    columns: about 3.5x faster than broadcasting over the length-3 last axis (a realistic
    scan turns a million sub-ray directions)."""
    columns = [np.ascontiguousarray(v[..., k]) for k in range(3)]
    out = np.empty(v.shape)
    for i in range(3):
        component = columns[0] * m[i, 0]
        component += columns[1] * m[i, 1]
        component += columns[2] * m[i, 2]
        out[..., i] = component
    return out


def matmul(a, b) -> np.ndarray:
    """a . b for 3x3 matrices (or stacks of them), each entry summed in index order."""
    a, b = as_array(a), as_array(b)
    out = a[..., :, 0, None] * b[..., None, 0, :]
    out += a[..., :, 1, None] * b[..., None, 1, :]
    out += a[..., :, 2, None] * b[..., None, 2, :]
    return out


def interp(x, xp, fp):
    """np.interp(x, xp, fp) for increasing xp, as numpy computes it (slope * (x - xp[j]) +
    fp[j], the end values outside), but as separate ufuncs: no compiler may fuse it."""
    x, xp, fp = as_array(x), as_array(xp), as_array(fp)
    n = len(xp)
    j = np.searchsorted(xp, x, side="right") - 1
    jc = np.clip(j, 0, max(n - 2, 0))
    if n == 1:
        return unwrap(np.where(x == x, fp[0], np.nan))
    with np.errstate(**ERRSTATE):
        slope = (fp[jc + 1] - fp[jc]) / (xp[jc + 1] - xp[jc])
        y = slope * (x - xp[jc]) + fp[jc]
        retry = slope * (x - xp[jc + 1]) + fp[jc + 1]
        y = np.where(y == y, y, np.where((retry != retry) & (fp[jc] == fp[jc + 1]), fp[jc], retry))
        y = np.where(xp[jc] == x, fp[jc], y)
        y = np.where(j < 0, fp[0], np.where(j >= n - 1, fp[-1], y))
        return unwrap(np.where(x == x, y, np.nan))
