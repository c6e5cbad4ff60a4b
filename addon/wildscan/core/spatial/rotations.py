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
    angle = dm.norm(w)
    small = angle < _SMALL
    safe = np.where(small, 1.0, angle)
    sin, cos = dm.sincos(angle)
    square = angle * angle
    a = np.where(small, 1 - square / 6, sin / safe)  # sin(a) / a
    b = np.where(small, 0.5 - square / 24, (1 - cos) / (safe * safe))  # (1 - cos a) / a^2
    cross = dm.cross(w, v)
    return v + a[..., None] * cross + b[..., None] * dm.cross(w, cross)


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
