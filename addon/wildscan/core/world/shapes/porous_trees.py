"""Trees a laser sees through (`--vegetation porous`, the default): the solid tree's size and
crown envelope (shapes/trees.py), grown as a branching skeleton (class trunk: trunk and
branches, visible inside the crown) carrying leaf clusters (class treetop) with gaps.

The three kinds stay distinct in what the scanner sees:

    conifer    one straight trunk to the top; whorls of near-horizontal branches every
               0.55-0.8 m, shortening upwards (a cone); flat needle sprays along them
    broadleaf  a short trunk forking into 3-4 limbs, each splitting into secondary
               branches that reach the wide round crown's edge; clusters around their tips
    birch      a slender trunk to the top; ascending branches with drooping tips in a
               narrow spindle; small clusters hanging in curtains

Leaf area per crown volume is LEAF_AREA_DENSITY (shapes/foliage.py explains the sizes
and the porosity they give). `rng` is the trees stage's own foliage generator, so the
solid shapes, drawn first from the stage's generator as before, and every placement stay
exactly as they were.
"""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from .foliage import (
    LEAF_SIZE,
    Skeleton,
    branch_path,
    cos_sin,
    directions,
    inside_ellipsoid,
    leaf_count,
    leaf_normals,
    leaf_triangles,
    ring_directions,
)
from .primitives import Mesh, lathe, merge
from .trees import TreeShape

# m^2 of leaf clusters per m^3 of crown envelope (tuned with `wildscan bench --suite realism`)
LEAF_AREA_DENSITY = {"conifer": 1.8, "broadleaf": 1.2, "birch": 1.2}


def _foliage(
    rng: np.random.Generator, sk: Skeleton, kind: str, volume: float, start: float, spread
) -> np.ndarray:
    """Leaf centres for a crown of `volume` m^3: along the skeleton's leafy branches,
    scattered by `spread` (metres, per axis)."""
    count = leaf_count(LEAF_AREA_DENSITY[kind] * volume, LEAF_SIZE[kind])
    return sk.points_along(rng, count, start) + rng.normal(0.0, 1.0, (count, 3)) * np.asarray(spread)


def porous_conifer(t: TreeShape, rng: np.random.Generator, d) -> tuple[Mesh, Mesh]:
    """(trunk and branches, needle sprays) of a fir."""
    h, r, tr, base = t.height, t.crown_radius, t.trunk_radius, t.envelope["crown_base"]
    trunk = lathe(
        [tr * 1.15, tr, tr * 0.8, tr * 0.45, 0.03],
        [-0.5, base * 0.5, base + 0.3, base + 0.55 * (h - base), h - 0.25],
        d.trunk_sides,
        cap_top=True,
    )
    sk = Skeleton(d.branch_sides)
    z = base + 0.15
    while z < h - 0.7:
        reach = max(0.35, r * (1.0 - (z - base) / (h - base)))
        count = int(rng.integers(4, 6))
        dirs = ring_directions(count, rng.uniform(0.0, 2.0 * math.pi), rng.uniform(-0.15, 0.05, count))
        for direction in dirs:
            length = reach * rng.uniform(0.8, 1.0)
            start = np.array([0.0, 0.0, z])
            path = branch_path(start, direction, length, 0.12 * length)[::2]  # straight: few triangles
            sk.add(path, _twig(length)[::2], length)
        z += rng.uniform(0.55, 0.8)
    volume = math.pi * r * r * (h - base) / 3.0
    centres = _foliage(rng, sk, "conifer", volume, 0.25, (0.18, 0.18, 0.07))
    crown = leaf_triangles(rng, centres, leaf_normals(rng, len(centres), 1.0), LEAF_SIZE["conifer"])
    return merge([trunk, sk.mesh()]), crown


def porous_broadleaf(t: TreeShape, rng: np.random.Generator, d) -> tuple[Mesh, Mesh]:
    """(trunk, limbs and branches, leaf clusters) of an oak."""
    e, tr = t.envelope, t.trunk_radius
    centre = np.array([0.0, 0.0, e["centre_z"]])
    axes = np.array([e["rx"], e["rx"], e["rz"]])
    fork = e["fork"]
    trunk = lathe(
        [tr * 1.2, tr, tr * 0.75, tr * 0.55], [-0.5, 0.0, fork, fork + 0.4], d.trunk_sides, cap_top=True
    )
    sk = Skeleton(d.branch_sides)
    root = np.array([0.0, 0.0, fork + 0.2])
    limbs = int(rng.integers(3, 5))
    dirs = ring_directions(limbs, rng.uniform(0.0, 2.0 * math.pi), rng.uniform(0.6, 0.95, limbs))
    for direction in dirs:
        end = inside_ellipsoid((centre + axes * direction * rng.uniform(0.5, 0.65))[None], centre, axes, 0.7)[
            0
        ]
        limb = np.stack([root, 0.5 * (root + end) + [0.0, 0.0, 0.25], end])
        sk.add(limb, [tr * 0.5, tr * 0.38, tr * 0.26])
        for _ in range(5):
            start = limb[1] + rng.uniform(0.0, 1.0) * (limb[2] - limb[1])
            aim = direction + rng.normal(0.0, 0.9, 3) + [0.0, 0.0, 0.2]
            aim /= dm.norm(aim)
            tip = inside_ellipsoid((start + aim * 0.7 * e["rx"])[None], centre, axes, rng.uniform(0.7, 0.85))[
                0
            ]
            length = float(dm.norm(tip - start))
            sk.add(np.stack([start, 0.5 * (start + tip) + [0.0, 0.0, 0.1], tip]), _twig(length), 0.5 * length)
            for _ in range(2):  # twigs out to the crown's edge, where most leaves are
                out = (tip - centre) / axes
                out = out / max(float(dm.norm(out)), 1e-9) + rng.normal(0.0, 0.5, 3)
                end = inside_ellipsoid((tip + out * axes * 0.4)[None], centre, axes, 0.97)[0]
                reach = float(dm.norm(end - tip))
                sk.add(np.stack([tip, end]), [0.012, 0.005], reach)
    top = centre + [0.0, 0.0, 0.7 * e["rz"]]
    sk.add(np.stack([root, 0.5 * (root + top), top]), [tr * 0.4, tr * 0.3, 0.03], 0.6 * e["rz"])
    volume = 4.0 / 3.0 * math.pi * e["rx"] * e["rx"] * e["rz"]
    centres = inside_ellipsoid(_foliage(rng, sk, "broadleaf", volume, 0.2, 0.55), centre, axes)
    crown = leaf_triangles(rng, centres, leaf_normals(rng, len(centres), 0.6), LEAF_SIZE["broadleaf"])
    return merge([trunk, sk.mesh()]), crown


def porous_birch(t: TreeShape, rng: np.random.Generator, d) -> tuple[Mesh, Mesh]:
    """(trunk, bare twigs and ascending branches, hanging leaf curtains) of a birch."""
    h, r, tr, base = t.height, t.crown_radius, t.trunk_radius, t.envelope["crown_base"]
    trunk = lathe(
        [tr * 1.1, tr, tr * 0.7, tr * 0.35, 0.025],
        [-0.5, 0.0, base + 0.4, 0.5 * (base + h), h - 0.2],
        d.trunk_sides,
        cap_top=True,
    )
    sk = Skeleton(d.branch_sides)
    for direction, z0 in zip(
        ring_directions(3, rng.uniform(0.0, 2.0 * math.pi), 0.5), rng.uniform(1.8, base - 0.5, 3)
    ):
        sk.add(branch_path([0.0, 0.0, z0], direction, rng.uniform(0.6, 1.0), 0.0), [0.03, 0.02, 0.012])
    count = int(rng.integers(12, 17))
    heights = base + (h - 0.8 - base) * (np.arange(count) + rng.uniform(0.2, 0.8, count)) / count
    golden = math.pi * (3.0 - math.sqrt(5.0))  # successive branches turn by the golden angle
    dirs = directions(
        rng.uniform(0.0, 2.0 * math.pi) + golden * np.arange(count), rng.uniform(0.55, 0.9, count)
    )
    reach = np.maximum(0.6, r * cos_sin(math.pi * (heights - base) / (h - base))[1])
    for z, direction, across in zip(heights, dirs, reach):
        length = across / max(float(dm.hypot(direction[0], direction[1])), 0.3)
        path = branch_path([0.0, 0.0, z], direction, length, 0.35 * length, 0.1 * length)
        sk.add(path, _twig(length, 0.8), length)
    volume = 0.56 * math.pi * r * r * (h - base)
    centres = _foliage(rng, sk, "birch", volume, 0.15, (0.25, 0.25, 0.15))
    centres[:, 2] -= rng.uniform(0.0, 0.7, len(centres))  # hanging curtains
    crown = leaf_triangles(rng, centres, leaf_normals(rng, len(centres), -1.0), LEAF_SIZE["birch"])
    return merge([trunk, sk.mesh()]), crown


def _twig(length: float, scale: float = 1.0) -> list[float]:
    """Radii at a branch's foot, middle and tip (metres) for its length."""
    return [scale * (0.018 + 0.01 * length), scale * (0.011 + 0.004 * length), 0.006]


POROUS_KINDS = {"conifer": porous_conifer, "broadleaf": porous_broadleaf, "birch": porous_birch}
