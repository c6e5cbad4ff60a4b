"""Rotations for poses in motion, vectorised (numpy only): rotation vectors (axis times angle)
between two attitudes, rotating many vectors by many rotation vectors, and unit quaternions.

Their numbers reach a drive's outputs (poses, deskewed points, swaying foliage), so every
sine, arctangent, norm and product is detmath's: the same bits on every CPU.
"""

from __future__ import annotations

import numpy as np

from .. import detmath as dm

# Below this angle (rad) sin(a)/a and (1 - cos a)/a^2 are taken from their Taylor series.
_SMALL = 1e-6


def log_map(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 3) rotation vectors (angle in [0, pi])."""
    r = np.asarray(r, dtype=np.float64)
    trace = np.trace(r, axis1=-2, axis2=-1)
    skew = np.stack(
        [r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0], r[..., 1, 0] - r[..., 0, 1]], -1
    )
    # atan2 keeps its precision at every angle (arccos of the trace alone loses it near 0 and pi)
    angle = dm.arctan2(dm.norm(skew) / 2, (trace - 1) / 2)
    sin = dm.sin(angle)
    small = angle < _SMALL
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(small, 0.5 + angle * angle / 12, angle / (2 * np.where(small, 1.0, sin)))
    out = skew * factor[..., None]
    near_pi = angle > np.pi - 1e-4  # the skew part vanishes: take the axis from the diagonal
    if np.any(near_pi):
        axis = _axis_near_pi(r[near_pi])
        axis *= np.where(dm.dot3(axis, skew[near_pi]) < 0, -1.0, 1.0)[:, None]
        out[near_pi] = axis * angle[near_pi][:, None]
    return out


def _axis_near_pi(r: np.ndarray) -> np.ndarray:
    sym = (r + np.swapaxes(r, -1, -2)) / 2 + np.eye(3)  # = 2 * axis axis^T at pi
    column = np.argmax(np.diagonal(sym, axis1=-2, axis2=-1), axis=-1)
    axis = sym[np.arange(len(r)), :, column]
    return axis / dm.norm(axis)[:, None]


def rotate(vectors: np.ndarray, rotvec: np.ndarray) -> np.ndarray:
    """Rotate vectors (N, 3) by rotation vectors (N, 3) (Rodrigues' formula)."""
    v = np.asarray(vectors, dtype=np.float64)
    w = np.asarray(rotvec, dtype=np.float64)
    return np.stack(rotate_columns([v[..., i] for i in range(3)], [w[..., i] for i in range(3)]), axis=-1)


def rotate_columns(v, w) -> list[np.ndarray]:
    """`rotate` on columns: `v` and `w` as their x, y and z arrays (each of one shape, or
    broadcasting), the rotated vectors' x, y and z returned. The same operations in the same
    order as on (N, 3) rows (norm, cross: detmath's order), element by element, so the same
    bits; on whole columns numpy's loops run over N values instead of 3 (a drive turns every
    beam of every sweep: this was the costliest part of a sweep's own work)."""
    v0, v1, v2 = (np.asarray(c, dtype=np.float64) for c in v)
    w0, w1, w2 = (np.asarray(c, dtype=np.float64) for c in w)
    angle = np.sqrt((w0 * w0 + w1 * w1) + w2 * w2)  # dm.norm
    small = angle < _SMALL
    safe = np.where(small, 1.0, angle)
    sin, cos = dm.sincos(angle)
    square = angle * angle
    a = np.where(small, 1 - square / 6, sin / safe)  # sin(a) / a
    b = np.where(small, 0.5 - square / 24, (1 - cos) / (safe * safe))  # (1 - cos a) / a^2
    c0, c1, c2 = w1 * v2 - w2 * v1, w2 * v0 - w0 * v2, w0 * v1 - w1 * v0  # w x v (dm.cross)
    d0, d1, d2 = w1 * c2 - w2 * c1, w2 * c0 - w0 * c2, w0 * c1 - w1 * c0  # w x (w x v)
    return [v0 + a * c0 + b * d0, v1 + a * c1 + b * d1, v2 + a * c2 + b * d2]


def matrix(rotvec: np.ndarray) -> np.ndarray:
    """(..., 3) rotation vectors -> (..., 3, 3) matrices."""
    w = np.asarray(rotvec, dtype=np.float64)
    eye = np.broadcast_to(np.eye(3), w.shape[:-1] + (3, 3))
    columns = [rotate(np.broadcast_to(eye[..., :, i], w.shape), w) for i in range(3)]
    return np.stack(columns, axis=-1)


def quaternions(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 4) unit quaternions (x, y, z, w), w >= 0.

    Shepperd's method: the largest of |w|, |x|, |y|, |z| comes from the diagonal, the others
    from sums and differences of the off-diagonal entries, so it is exact near 180 deg too."""
    r = np.asarray(r, dtype=np.float64)
    shape = r.shape[:-2]
    r = r.reshape(-1, 3, 3)
    m00, m11, m22 = r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]
    d21, d02, d10 = r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]
    s21, s02, s10 = r[:, 2, 1] + r[:, 1, 2], r[:, 0, 2] + r[:, 2, 0], r[:, 1, 0] + r[:, 0, 1]
    big = np.stack([m00 + m11 + m22, m00 - m11 - m22, m11 - m00 - m22, m22 - m00 - m11], axis=1)
    pick = np.argmax(big, axis=1)
    t = np.sqrt(np.maximum(1 + big[np.arange(len(r)), pick], 1e-300)) * 2  # 4 * the largest component
    candidates = np.stack(
        [
            np.stack([d21, d02, d10, t * t / 4], axis=1),  # w largest
            np.stack([t * t / 4, s10, s02, d21], axis=1),  # x largest
            np.stack([s10, t * t / 4, s21, d02], axis=1),  # y largest
            np.stack([s02, s21, t * t / 4, d10], axis=1),  # z largest
        ],
        axis=1,
    )
    q = candidates[np.arange(len(r)), pick] / t[:, None]
    q *= np.where(q[:, 3] < 0, -1.0, 1.0)[:, None]
    q /= np.sqrt(((q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1]) + q[:, 2] * q[:, 2]) + q[:, 3] * q[:, 3])[:, None]
    return q.reshape(shape + (4,))
