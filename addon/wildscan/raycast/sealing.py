"""What a sealed float32 caster and its float64 settling read of a geometry, made in one pass
(numpy only): each triangle's plane, its padded copy and its settling band.

The same bits as the three separate steps (geometry._planes, padding.pad_triangles,
settle._band: tests/test_sealing.py compares them on worlds and on degenerate triangles),
about 3x faster on a porous world's million triangles (~0.8 s of a 4 s world build):

- shared work: the plane's normal is the cross product whose length the padding needs (twice
  the area), and |v0 - v1| is |v1 - v0|, so each is computed once;
- one coordinate at a time: each step reads contiguous columns of a block of triangles
  instead of the stride-3 views of (T, 3) rows the vector helpers take, and nothing is
  stacked into (T, 3) temporaries;
- a block of BLOCK_ROWS triangles at a time (raycast/blocks.py), so the temporaries stay in
  the CPU's cache.

Every value is the same sequence of IEEE operations as before (products and sums in the
order core/detmath writes them), so the bytes cannot differ on any CPU.
"""

from __future__ import annotations

import numpy as np

from .blocks import BLOCK_ROWS
from .padding import _MAX_PAD_STRETCH, MIN_EDGE_PAD, PAD_ULPS
from .settle import BAND_MARGIN, Settler


def sealed_settler(geometry) -> Settler:
    """Settler.sealing(geometry, geometry.local_planes(corners), corners) with its `band`
    made too, where corners = geometry.local_triangles(): the same arrays, one pass."""
    corners = local_corners(geometry)
    normal, d, padded, band = sealing_arrays(corners)
    settler = Settler(geometry, padded, (normal, d), corners)
    settler.__dict__["band"] = band  # what cached_property keeps
    return settler


def local_corners(geometry) -> np.ndarray:
    """geometry.local_triangles(): (T, 3, 3) offset-local float64 corners, each the same
    subtraction (vertex - offset), gathered a block of triangles at a time straight into the
    result, without the (V, 3) array of shifted vertices (55 MB for seed 0's porous world)
    that local_triangles makes first."""
    faces, vertices, offset = geometry.faces, geometry.vertices, geometry.offset
    corners = np.empty((len(faces), 3, 3))
    for start in range(0, len(faces), BLOCK_ROWS):
        rows = slice(start, start + BLOCK_ROWS)
        np.subtract(vertices.take(faces[rows], axis=0), offset, out=corners[rows])
    return corners


def edge_pad(corners: np.ndarray) -> float:
    """padding.edge_pad(corners) without the |corners| temporary: max |x| is the larger of
    max x and -min x (the same value)."""
    if not corners.size:
        return MIN_EDGE_PAD
    extent = float(np.maximum(corners.max(), -corners.min()))
    return max(MIN_EDGE_PAD, PAD_ULPS * float(np.finfo(np.float32).eps) * extent)


def sealing_arrays(corners: np.ndarray, pad: float | None = None):
    """(normal (T, 3), d (T,), padded (T, 3, 3) float64, band (T,) float32) of the (T, 3, 3)
    offset-local float64 triangles `corners`: geometry.local_planes, padded_local_triangles
    (dtype float64, pad `edge_pad` unless given) and Settler.band, bit for bit."""
    corners = np.ascontiguousarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    pad = edge_pad(corners) if pad is None else float(pad)
    count = len(corners)
    normal = np.empty((count, 3))
    d = np.empty(count)
    padded = np.empty((count, 3, 3))
    band = np.empty(count, dtype=np.float32)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for start in range(0, count, BLOCK_ROWS):
            rows = slice(start, min(start + BLOCK_ROWS, count))
            _block(corners[rows], pad, normal[rows], d[rows], padded[rows], band[rows])
    return normal, d, padded, band


def _length(x, y, z):
    """detmath.norm of the vector (x, y, z): sqrt((x x + y y) + z z)."""
    return np.sqrt(x * x + y * y + z * z)


def _block(tri, pad, normal_out, d_out, padded_out, band_out) -> None:
    """One block's planes, padded corners and bands, written into the *_out views."""
    v = [[np.ascontiguousarray(tri[:, k, c]) for c in range(3)] for k in range(3)]  # v[corner][axis]
    (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = v
    # edges from corner 0 (the plane's and the area's), and v1 - v2 (the side facing corner 0)
    px, py, pz = x1 - x0, y1 - y0, z1 - z0
    qx, qy, qz = x2 - x0, y2 - y0, z2 - z0
    cx, cy, cz = py * qz - pz * qy, pz * qx - px * qz, px * qy - py * qx  # detmath.cross(p, q)
    double_area = _length(cx, cy, cz)
    # the plane (geometry._planes): unit normal, zero where degenerate, and n . v0
    unit = np.where(double_area > 0, double_area, 1.0)
    nx, ny, nz = cx / unit, cy / unit, cz / unit
    normal_out[:, 0], normal_out[:, 1], normal_out[:, 2] = nx, ny, nz
    d_out[:] = nx * x0 + ny * y0 + nz * z0
    # the padding (padding.pad_triangles): side lengths opposite each corner
    a = _length(x1 - x2, y1 - y2, z1 - z2)
    b = _length(qx, qy, qz)  # |v2 - v0|
    c = _length(px, py, pz)  # |v0 - v1| = |v1 - v0|: the same squares
    perimeter = a + b + c
    ok = (double_area > 0) & (perimeter > 0)
    safe_perimeter = np.where(ok, perimeter, 1.0)
    inradius = np.where(ok, double_area / safe_perimeter, 1.0)
    centre = [(a * v[0][k] + b * v[1][k] + c * v[2][k]) / safe_perimeter for k in range(3)]
    limit = _MAX_PAD_STRETCH * pad
    grown = []  # grown[corner][axis]
    for k in range(3):
        away = [v[k][axis] - centre[axis] for axis in range(3)]
        length = _length(*away)
        shift = np.minimum(pad * length / inradius, limit)
        moves = length > 0
        scale = np.where(ok & moves, shift / np.where(moves, length, 1.0), 0.0)
        grown.append([v[k][axis] + away[axis] * scale for axis in range(3)])
        for axis in range(3):
            padded_out[:, k, axis] = grown[k][axis]
    # the settling band (settle._band) of the padded triangle over the unpadded one
    shift = None
    for k in range(3):
        moved = _length(*(grown[k][axis] - v[k][axis] for axis in range(3)))
        shift = moved if shift is None else np.maximum(shift, moved)
    (gx0, gy0, gz0), (gx1, gy1, gz1), (gx2, gy2, gz2) = grown
    ex, ey, ez = gx1 - gx0, gy1 - gy0, gz1 - gz0
    fx, fy, fz = gx2 - gx0, gy2 - gy0, gz2 - gz0
    grown_area = _length(ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx)
    longest = np.maximum(
        np.maximum(_length(gx0 - gx2, gy0 - gy2, gz0 - gz2), _length(ex, ey, ez)),
        _length(gx2 - gx1, gy2 - gy1, gz2 - gz1),
    )
    value = 2.0 * shift * longest / grown_area + BAND_MARGIN
    band_out[:] = np.where(grown_area > 0, value, np.inf)
