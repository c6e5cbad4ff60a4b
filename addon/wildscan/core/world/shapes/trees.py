"""Trees: a trunk (with its branches) and a crown, two elements sharing one placement.

`d` is the world's DetailLevel (sides and subdivisions per shape). These are the solid
crowns (the paper's look, `--vegetation solid`); each also records its crown's envelope,
from which shapes/porous_trees.py grows the same tree as skeleton and leaf clusters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ... import detmath as dm
from .primitives import Mesh, icosphere, lathe, lumpy, merge, tapered_tube


@dataclass
class TreeShape:
    kind: str
    trunk: Mesh
    crown: Mesh
    height: float
    crown_radius: float
    trunk_radius: float
    # the crown's extent, for the porous version: crown_base (m above the foot) for a
    # conifer or birch; centre_z, rx, rz and fork for a broadleaf
    envelope: dict = field(default_factory=dict)


def _ellipsoid_entry(p0, p1, centre, axes) -> float:
    """Parameter t in [0,1] where segment p0->p1 enters the ellipsoid (1 if it never does)."""
    a = (np.asarray(p1) - p0) / axes
    b = (np.asarray(p0) - centre) / axes
    qa, qb, qc = dm.dot3(a, a), 2 * dm.dot3(a, b), dm.dot3(b, b) - 1.0
    disc = qb * qb - 4 * qa * qc
    if disc < 0:
        return 1.0
    t = (-qb - math.sqrt(disc)) / (2 * qa)
    return float(np.clip(t, 0.0, 1.0))


def conifer(rng: np.random.Generator, d) -> TreeShape:
    """A fir: straight trunk into a tiered conical crown."""
    height = rng.uniform(10.0, 14.0)
    crown_base = rng.uniform(2.0, 3.0)
    radius = rng.uniform(2.0, 2.8)
    trunk_r = rng.uniform(0.18, 0.26)
    trunk = lathe(
        [trunk_r * 1.15, trunk_r, trunk_r * 0.8],
        [-0.5, crown_base * 0.5, crown_base + 0.3],
        d.trunk_sides,
        cap_top=True,
    )
    tiers = 3
    tier_h = (height - crown_base) / tiers
    r, z = [0.0], [crown_base]
    for k in range(tiers):
        top_r = radius * (1.0 - (k + 1) / (tiers + 0.6))
        r += [radius * (1.0 - k / (tiers + 0.6)), max(top_r * 0.55, 0.15)]
        z += [crown_base + k * tier_h + 0.35, crown_base + (k + 1) * tier_h - 0.1 * tier_h]
    r.append(0.0)
    z.append(height)
    crown = lathe(r, z, d.crown_sides, phase=rng.uniform(0, 1))
    return TreeShape("conifer", trunk, crown, height, radius, trunk_r, {"crown_base": crown_base})


def broadleaf(rng: np.random.Generator, d) -> TreeShape:
    """An oak: trunk forking into branches that end just inside a lumpy round crown."""
    height = rng.uniform(8.5, 11.0)
    rx = rng.uniform(2.6, 3.4)
    rz = rng.uniform(2.2, 2.8)
    centre = np.array([0.0, 0.0, height - rz])
    fork = centre[2] - rz - rng.uniform(1.0, 1.6)
    trunk_r = rng.uniform(0.25, 0.35)
    axes = np.array([rx, rx, rz])
    trunk_top = centre[2] - rz * 0.8
    parts = [
        lathe(
            [trunk_r * 1.2, trunk_r, trunk_r * 0.75, trunk_r * 0.5],
            [-0.5, 0.0, fork, trunk_top],
            d.trunk_sides,
            cap_top=True,
        )
    ]
    n_branches = int(rng.integers(3, 5))
    for k in range(n_branches):
        a = 2 * math.pi * k / n_branches + rng.uniform(-0.4, 0.4)
        start = np.array([0.0, 0.0, fork - 0.2])
        sin, cos = dm.sincos(a)
        target = centre + np.array([0.6 * rx * cos, 0.6 * rx * sin, -0.2 * rz])
        t = _ellipsoid_entry(start, target, centre, axes * 0.98)
        end = start + (target - start) * min(1.0, t + 0.3 / dm.norm(target - start))
        mid = 0.5 * (start + end) + [0.0, 0.0, 0.15]
        parts.append(
            tapered_tube([start, mid, end], [trunk_r * 0.45, trunk_r * 0.33, trunk_r * 0.22], d.branch_sides)
        )
    crown = lumpy(icosphere(d.sphere_subdivisions), rng, 0.12)
    crown = (crown[0] * axes + centre, crown[1])
    envelope = {"centre_z": float(centre[2]), "rx": rx, "rz": rz, "fork": float(fork)}
    return TreeShape("broadleaf", merge(parts), crown, height, rx, trunk_r, envelope)


def birch(rng: np.random.Generator, d) -> TreeShape:
    """A birch: slender trunk, a few bare twigs low down, a narrow spindle crown."""
    height = rng.uniform(11.0, 14.0)
    crown_base = height * rng.uniform(0.35, 0.45)
    radius = rng.uniform(1.5, 2.1)
    trunk_r = rng.uniform(0.12, 0.16)
    parts = [
        lathe(
            [trunk_r * 1.1, trunk_r, trunk_r * 0.7],
            [-0.5, 0.0, crown_base + 0.4],
            d.trunk_sides,
            cap_top=True,
        )
    ]
    for _ in range(int(rng.integers(2, 4))):
        a = rng.uniform(0, 2 * math.pi)
        z0 = rng.uniform(1.8, crown_base - 0.5)
        length = rng.uniform(0.7, 1.2)
        start = np.array([0.0, 0.0, z0])
        sin, cos = dm.sincos(a)
        end = start + length * np.array([cos * 0.85, sin * 0.85, 0.5])
        parts.append(tapered_tube([start, end], [0.045, 0.02], d.branch_sides))
    t = np.linspace(0.0, 1.0, d.crown_rings + 2)
    r = radius * dm.exp(0.8 * dm.log(dm.sin(np.pi * t)[1:-1]))  # sin^0.8 (np.power is per CPU)
    r = np.concatenate([[0.0], r, [0.0]])
    crown = lathe(r, crown_base + t * (height - crown_base), d.crown_sides, phase=rng.uniform(0, 1))
    crown = lumpy(((crown[0] - [0, 0, (crown_base + height) / 2]), crown[1]), rng, 0.08)
    crown = (crown[0] + [0, 0, (crown_base + height) / 2], crown[1])
    return TreeShape("birch", merge(parts), crown, height, radius, trunk_r, {"crown_base": crown_base})


TREE_KINDS = {"conifer": conifer, "broadleaf": broadleaf, "birch": birch}
