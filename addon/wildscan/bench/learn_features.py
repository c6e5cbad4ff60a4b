"""The learn suite's per-point features (numpy only): geometry a sensor gives, computed from
one SemanticKITTI scan's points and its pose, never from labels, world or intensity.

The points are turned to the world's axes about the optical centre (poses.txt's rotation,
so the features do not depend on the dataset's frame), then each point gets:

- range, its height relative to the sensor, and the elevation angle of its beam;
- columns (vertical prisms) of COLUMN_CELLS metres: height above the column's lowest return
  (a stand-in for the ground), below its highest, the column's height spread and its point
  density (count × cell⁻² normalised by range², the sampling of a scanning sensor thinning
  as 1/R²);
- voxels of VOXEL_SIZES metres: the eigen features of their points' covariance (linearity,
  planarity, scattering: Weinmann et al., "Semantic point cloud interpretation based on
  optimal neighborhoods, relevant features and efficient classifiers", ISPRS J. Photogramm.
  105, 2015, Sec. 3.2), verticality (1 − |n_z| of the smallest eigenvector) and the RMS
  spread;
- depth jumps to the previous and next point of the file (a 2D scan's neighbouring beams,
  0.25° apart on the UTM-30LX-EW): edges of trunks, poles and wires;
- with_intensity only: the remission.
"""

from __future__ import annotations

import numpy as np

COLUMN_CELLS = (0.5, 2.0)  # m
VOXEL_SIZES = (0.25, 1.0)  # m


def feature_names(with_intensity: bool = False) -> list[str]:
    names = ["range", "z_sensor", "elevation"]
    for c in COLUMN_CELLS:
        names += [f"above_lowest_{c:g}m", f"below_highest_{c:g}m", f"column_spread_{c:g}m", f"density_{c:g}m"]
    for v in VOXEL_SIZES:
        names += [f"{k}_{v:g}m" for k in ("linearity", "planarity", "scattering", "verticality", "rms")]
    names += ["jump_prev", "jump_next"]
    if with_intensity:
        names.append("remission")
    return names


def scan_features(xyz: np.ndarray, rotation: np.ndarray, remission=None, pick=None) -> np.ndarray:
    """float32 (len(pick), F) features of the points `pick` (all when None) of one scan, in
    the order of feature_names; neighbourhoods use every point of the scan."""
    p = np.asarray(xyz, dtype=np.float64) @ np.asarray(rotation, dtype=np.float64).T
    pick = np.arange(len(p)) if pick is None else np.asarray(pick)
    r = np.linalg.norm(p, axis=1)
    cols = [r[pick], p[pick, 2], np.arctan2(p[pick, 2], np.hypot(p[pick, 0], p[pick, 1]))]
    for cell in COLUMN_CELLS:
        cols += _column_features(p, r, cell, pick)
    for size in VOXEL_SIZES:
        cols += _voxel_features(p, size, pick)
    cols += [j[pick] for j in _jumps(r)]
    if remission is not None:
        cols.append(np.asarray(remission, dtype=np.float64)[pick])
    return np.stack(cols, axis=1).astype(np.float32)


def _cells(keys: np.ndarray) -> tuple[np.ndarray, int]:
    """A dense index per distinct row of integer keys (one int64 key a row: a 1D sort is
    many times faster than np.unique over rows), and how many there are."""
    if not len(keys):
        return np.zeros(0, dtype=np.int64), 0
    keys = keys - keys.min(axis=0)
    span = keys.max(axis=0) + 1
    flat = np.zeros(len(keys), dtype=np.int64)
    for k in range(keys.shape[1]):
        flat = flat * span[k] + keys[:, k]
    _, inverse = np.unique(flat, return_inverse=True)
    inverse = inverse.ravel()
    return inverse, int(inverse.max()) + 1


def _column_features(p: np.ndarray, r: np.ndarray, cell: float, pick: np.ndarray) -> list[np.ndarray]:
    idx, n = _cells(np.floor(p[:, :2] / cell).astype(np.int64))
    z = p[:, 2]
    low = np.full(n, np.inf)
    high = np.full(n, -np.inf)
    np.minimum.at(low, idx, z)
    np.maximum.at(high, idx, z)
    count = np.bincount(idx, minlength=n).astype(np.float64)
    mean = np.bincount(idx, z, n) / count
    var = np.maximum(np.bincount(idx, z * z, n) / count - mean**2, 0.0)
    i, zp = idx[pick], z[pick]
    density = count[i] / cell**2 * (np.maximum(r[pick], 0.5) / 10.0) ** 2
    return [zp - low[i], high[i] - zp, np.sqrt(var)[i], density]


def _voxel_features(p: np.ndarray, size: float, pick: np.ndarray) -> list[np.ndarray]:
    idx, n = _cells(np.floor(p / size).astype(np.int64))
    count = np.bincount(idx, minlength=n).astype(np.float64)
    mean = np.stack([np.bincount(idx, p[:, k], n) for k in range(3)], axis=1) / count[:, None]
    d = p - mean[idx]
    cov = np.empty((n, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = np.bincount(idx, d[:, a] * d[:, b], n) / count
    used, at = np.unique(idx[pick], return_inverse=True)  # eigen only where a picked point is
    values, vectors = np.linalg.eigh(cov[used])  # ascending
    count = count[used]
    l3, l2, l1 = (np.maximum(values[:, k], 0.0) for k in range(3))
    safe = np.where(l1 > 0, l1, 1.0)
    linearity = np.where(l1 > 0, (l1 - l2) / safe, 0.0)
    planarity = np.where(l1 > 0, (l2 - l3) / safe, 0.0)
    scattering = np.where(l1 > 0, l3 / safe, 0.0)
    verticality = 1.0 - np.abs(vectors[:, 2, 0])
    few = count < 3  # no shape from fewer than 3 points
    for f in (linearity, planarity, scattering, verticality):
        f[few] = -1.0
    rms = np.sqrt(l1 + l2 + l3)
    at = at.ravel()
    return [f[at] for f in (linearity, planarity, scattering, verticality, rms)]


def _jumps(r: np.ndarray) -> list[np.ndarray]:
    """|Δrange| to the previous and the next point of the file (0 at the ends)."""
    step = np.abs(np.diff(r))
    prev = np.concatenate([[0.0], step])
    nxt = np.concatenate([step, [0.0]])
    return [prev, nxt]
