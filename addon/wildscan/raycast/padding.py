"""Closing the cracks between triangles (numpy only): each triangle grown in its own plane by a
few float32 ulps, so a float32 caster lets no ray slip between neighbours (what
`SceneGeometry.padded_local_triangles` gives every sealed caster; sealing.py makes the same
bits in one pass).
"""

from __future__ import annotations

import numpy as np

from ..core import detmath as dm

# -- closing the cracks between triangles -------------------------------------------------

# In-plane growth of a triangle: 8 float32 spacings (ulps) of the largest offset-local
# coordinate, at least 10 µm. One ulp already closes every crack the stability tests
# find; 8 is margin. Within a cropped scan (coordinates <= ~35 m) that is ~3e-5 m,
# far below anything a 15 mm-noise sensor can see.
PAD_ULPS = 8.0
MIN_EDGE_PAD = 1e-5
# A vertex never moves more than this many pads (very acute corners of slivers).
_MAX_PAD_STRETCH = 20.0


def edge_pad(local_coordinates: np.ndarray) -> float:
    """The pad that float32 coordinates of this size need: well above their rounding."""
    extent = float(np.abs(local_coordinates).max()) if local_coordinates.size else 0.0
    return max(MIN_EDGE_PAD, PAD_ULPS * float(np.finfo(np.float32).eps) * extent)


def pad_triangles(tris: np.ndarray, pad: float) -> np.ndarray:
    """Grow each triangle (T,3,3) in its own plane so that each edge moves outward by `pad`.

    Why: single-precision ray/triangle tests (Embree, BVHTree) are not watertight;
    a ray through a shared edge or vertex can slip between the two triangles and
    report the surface behind, or nothing (the stability tests measure it). With
    every triangle overlapping its neighbours by `pad`, such a ray hits one of them.
    Growing in-plane keeps each triangle's plane, so float64 refined ranges are
    unchanged; silhouettes grow by `pad` (10-30 µm in a cropped scan).

    Offsetting all three edges by `pad` is a scaling about the incentre by
    (r + pad) / r (r the inradius). Slivers' acute corners would shoot far out,
    so no vertex moves more than _MAX_PAD_STRETCH pads; degenerate triangles stay.
    """
    tris = np.asarray(tris, dtype=np.float64)
    v0, v1, v2 = tris[:, 0], tris[:, 1], tris[:, 2]
    a = dm.norm(v1 - v2)  # side lengths opposite each vertex
    b = dm.norm(v2 - v0)
    c = dm.norm(v0 - v1)
    perimeter = a + b + c
    double_area = dm.norm(dm.cross(v1 - v0, v2 - v0))
    ok = (double_area > 0) & (perimeter > 0)
    safe_perimeter = np.where(ok, perimeter, 1.0)
    inradius = np.where(ok, double_area / safe_perimeter, 1.0)
    incentre = (a[:, None] * v0 + b[:, None] * v1 + c[:, None] * v2) / safe_perimeter[:, None]
    out = tris.copy()
    for k in range(3):
        away = tris[:, k] - incentre
        length = dm.norm(away)
        shift = np.minimum(pad * length / inradius, _MAX_PAD_STRETCH * pad)
        scale = np.where(ok & (length > 0), shift / np.where(length > 0, length, 1.0), 0.0)
        out[:, k] += away * scale[:, None]
    return out


# -- float64 hit refinement (shared by the float32 backends) -----------------------------
