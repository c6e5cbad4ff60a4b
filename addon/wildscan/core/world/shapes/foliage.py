"""Vegetation a laser beam can pass through: branching skeletons carrying leaf clusters, and
grass blades (numpy only).

Modelled no finer than the sensor resolves. Its beams are 0.25 deg apart along a scan
line (4.4 cm at 10 m, 2.2 cm at 5 m) and its footprint about as wide (core/realism/footprint.py,
4.4 mrad), so:

  * a leaf cluster is one triangle LEAF_SIZE across (0.16-0.22 m): at the 5-15 m a
    forest is seen from it spans 2-8 beam spacings, so every cluster is seen as a
    surface, and the gaps between clusters, of the same size, as gaps. Single leaves
    (5 cm) would sit under one footprint and only add noise and mixed pixels.
  * branches are tubes of BRANCH_SIDES-ish facets, 1.5-5 cm thick: thin enough to be
    missed between beams at range, as real twigs are.
  * a grass blade is one triangle 2.5-4 cm wide at its foot: about one beam spacing at
    the few metres grass is seen from.

How porous: the leaf area per crown volume (LEAF_AREA_DENSITY, m^2/m^3) is chosen so
that a horizontal beam through 3 m of crown passes with probability 20-50 % and the sky
seen from under the forest canopy is 15-35 % (`wildscan bench --suite realism`
measures both; docs/validation.md "Vegetation"). For random leaf angles Beer-Lambert's gap fraction
is exp(-G * LAD * path) with G = 0.5; clustering leaves along branches leaves more gaps
than that.

Every mesh is a prototype shared by all trees of a kind and variant. Transcendental
calls are gathered in `_leaf_corners` (the leaf triangles) and `_cos_sin` (directions
around a trunk); the rest is products and sums.
"""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from .primitives import Mesh, merge, tapered_tube

LEAF_SIZE = {"conifer": 0.3, "broadleaf": 0.3, "birch": 0.22, "bush": 0.13}  # m, triangle side
BLADE_WIDTH = (0.025, 0.04)  # m at the foot


def cos_sin(angles):
    """cos and sin of angles (radians): every cosine and sine of the porous shapes."""
    sin, cos = dm.sincos(angles)
    return cos, sin


def _leaf_corners(spin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of the three corner directions of each leaf triangle, (K, 3) each: spin,
    spin + 120 deg, spin + 240 deg."""
    corners = spin[:, None] + (2.0 * math.pi / 3.0) * np.arange(3)[None, :]
    return cos_sin(corners)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / dm.norm(v)[..., None]


def leaf_normals(rng: np.random.Generator, count: int, up: float) -> np.ndarray:
    """Random unit normals, tilted towards +Z by `up` (0: any direction; 2: mostly flat
    leaves facing the sky; negative values lean them towards horizontal)."""
    n = rng.normal(size=(count, 3))
    if up >= 0:
        n[:, 2] = np.abs(n[:, 2]) + up
    else:
        n[:, 2] *= 1.0 / (1.0 - up)
    return _unit(n)


def leaf_triangles(rng: np.random.Generator, centres: np.ndarray, normals: np.ndarray, size: float) -> Mesh:
    """One equilateral triangle of side about `size` (+-25 %) per centre, in the plane its
    normal gives, turned at random in that plane."""
    k = len(centres)
    if k == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32)
    ref = np.where(np.abs(normals[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    e1 = _unit(np.cross(normals, ref))
    e2 = np.cross(normals, e1)
    radius = size * rng.uniform(0.75, 1.25, k) / math.sqrt(3.0)  # circumradius
    cos_c, sin_c = _leaf_corners(rng.uniform(0.0, 2.0 * math.pi, k))
    verts = centres[:, None, :] + radius[:, None, None] * (
        cos_c[:, :, None] * e1[:, None, :] + sin_c[:, :, None] * e2[:, None, :]
    )
    faces = np.arange(3 * k, dtype=np.int32).reshape(k, 3)
    return verts.reshape(-1, 3), faces


def leaf_count(area: float, size: float) -> int:
    """Leaf triangles of side `size` (on average) making up `area` m^2 of foliage."""
    return max(1, int(round(area / (math.sqrt(3.0) / 4.0 * size * size))))


# ---------------------------------------------------------------------------------------
# skeletons


class Skeleton:
    """Branches as polylines with radii; leaves grow along the outer part of each."""

    def __init__(self, sides: int):
        self.sides = sides
        self.parts: list[Mesh] = []
        self.branches: list[tuple[np.ndarray, float]] = []  # (path (K,3), foliage weight)

    def add(self, path, radii, foliage: float = 0.0) -> None:
        path = np.asarray(path, dtype=np.float64)
        self.parts.append(tapered_tube(path, np.asarray(radii, dtype=np.float64), self.sides))
        if foliage > 0:
            self.branches.append((path, foliage))

    def mesh(self) -> Mesh:
        return merge(self.parts)

    def points_along(self, rng: np.random.Generator, count: int, start: float = 0.3) -> np.ndarray:
        """`count` points spread over the branches by their foliage weight, each at a random
        place on the outer (1 - start) of its branch."""
        weights = np.array([w for _, w in self.branches])
        which = rng.choice(len(self.branches), size=count, p=weights / weights.sum())
        u = start + (1.0 - start) * np.sqrt(rng.uniform(0.0, 1.0, count))  # denser towards the tips
        out = np.empty((count, 3))
        for b, (path, _) in enumerate(self.branches):
            mine = which == b
            out[mine] = polyline_point(path, u[mine])
        return out


def polyline_point(path: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points at fractions `u` (0..1) of a polyline's length."""
    seg = dm.norm(np.diff(path, axis=0))
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.asarray(u) * cum[-1]
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    f = (s - cum[i]) / np.where(seg[i] > 0, seg[i], 1.0)
    return path[i] + f[:, None] * (path[i + 1] - path[i])


def branch_path(start, direction, length: float, droop: float, bend: float = 0.0) -> np.ndarray:
    """A three-point branch from `start` along unit `direction` for `length`, its tip
    dropped by `droop` metres and its middle raised by `bend`."""
    start = np.asarray(start, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    mid = start + 0.5 * length * d + [0.0, 0.0, bend - 0.25 * droop]
    tip = start + length * d - [0.0, 0.0, droop]
    return np.stack([start, mid, tip])


def directions(azimuth, elevation) -> np.ndarray:
    """Unit directions (K, 3) at azimuths (radians, CCW from +X) raised by elevations
    (radians above the horizontal)."""
    azimuth = np.asarray(azimuth, dtype=np.float64)
    cos_a, sin_a = cos_sin(azimuth)
    cos_e, sin_e = cos_sin(np.broadcast_to(np.asarray(elevation, dtype=np.float64), azimuth.shape))
    return np.stack([cos_a * cos_e, sin_a * cos_e, sin_e], -1)


def ring_directions(count: int, phase: float, elevation) -> np.ndarray:
    """`count` unit directions evenly around the vertical from `phase`, each raised by its
    `elevation` (radians)."""
    return directions(phase + 2.0 * math.pi * np.arange(count) / count, elevation)


def inside_ellipsoid(points: np.ndarray, centre, axes, margin: float = 1.0) -> np.ndarray:
    """Points pulled radially into the ellipsoid (centre, semi-axes) scaled by `margin`."""
    q = (points - centre) / axes
    r = dm.norm(q)
    scale = np.where(r > margin, margin / np.maximum(r, 1e-12), 1.0)
    return centre + q * scale[:, None] * axes


# ---------------------------------------------------------------------------------------
# grass


def blades(rng: np.random.Generator, height: float, spread: float, count: int) -> Mesh:
    """A tuft of `count` separate blades, one triangle each, BLADE_WIDTH wide at the foot,
    rising from a disc of diameter `spread` to 60-100 % of `height` and leaning outwards."""
    cos_a, sin_a = cos_sin(rng.uniform(0.0, 2.0 * math.pi, count))
    foot_r = 0.5 * spread * np.sqrt(rng.uniform(0.0, 1.0, count))
    outward = np.stack([cos_a, sin_a, np.zeros(count)], -1)
    foot = outward * foot_r[:, None] + [0.0, 0.0, -0.04]
    cos_f, sin_f = cos_sin(rng.uniform(0.0, 2.0 * math.pi, count))  # the blade's facing
    across = (
        np.stack([-sin_f, cos_f, np.zeros(count)], -1) * (0.5 * rng.uniform(*BLADE_WIDTH, count))[:, None]
    )
    tip_h = height * rng.uniform(0.6, 1.0, count)
    lean = tip_h * rng.uniform(0.1, 0.35, count)
    tip = foot + outward * lean[:, None] + np.stack([np.zeros(count), np.zeros(count), tip_h + 0.04], -1)
    verts = np.stack([foot - across, foot + across, tip], 1).reshape(-1, 3)
    return verts, np.arange(3 * count, dtype=np.int32).reshape(count, 3)
