"""Bushes and grass tufts: solid (`--vegetation solid`, the paper's look) and porous (stems
carrying leaf clusters; separate blades)."""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from .foliage import (
    LEAF_SIZE,
    Skeleton,
    blades,
    directions,
    inside_ellipsoid,
    leaf_count,
    leaf_normals,
    leaf_triangles,
)
from .primitives import Mesh, drop_buried, icosphere, lumpy, merge, scaled

BUSH_LEAF_AREA_DENSITY = 2.2  # m^2 of leaf clusters per m^3: a bush is denser than a crown
HIGH_GRASS_BLADES = 12


def bush(rng: np.random.Generator, d) -> tuple[Mesh, float]:
    """A lumpy dome about 1.2 m wide and 0.9 m high at scale 1; returns (mesh, radius)."""
    radius = rng.uniform(0.55, 0.75)
    m = lumpy(icosphere(d.bush_subdivisions), rng, 0.18)
    m = scaled(m, radius, radius, radius * 0.8, dz=radius * 0.45)
    return drop_buried(m, -0.05), radius


def tuft(rng: np.random.Generator, height: float, spread: float, planes: int, blades: int) -> Mesh:
    """A grass tuft: `planes` crossed vertical zig-zags of `blades` single-triangle blades.

    planes * blades triangles in all (e.g. 3 x 3 = 9): enough for the beams to
    see a tuft's height and width, nothing a 6 cm beam spacing could not see.
    """
    verts, faces = [], []
    n = 0
    for p in range(planes):
        angle = math.pi * p / planes + rng.uniform(-0.2, 0.2)
        s, c = dm.sincos(angle)
        base_u = np.linspace(-spread / 2, spread / 2, blades + 1)
        tips_u = 0.5 * (base_u[:-1] + base_u[1:]) + rng.uniform(-0.35, 0.35, blades) * spread / blades * 2
        tips_h = height * rng.uniform(0.6, 1.0, blades)
        lean = rng.uniform(-0.15, 0.15, blades) * height
        base = np.stack([base_u * c, base_u * s, np.full(blades + 1, -0.04)], -1)
        tips = np.stack([tips_u * c - lean * s, tips_u * s + lean * c, tips_h], -1)
        verts += [base, tips]
        k = np.arange(blades)
        faces.append(np.stack([n + k, n + k + 1, n + blades + 1 + k], -1))
        n += 2 * blades + 1
    return np.concatenate(verts), np.concatenate(faces).astype(np.int32)


def porous_bush(radius: float, rng: np.random.Generator, d) -> Mesh:
    """The bush `bush` drew (its radius), as stems fanning out from the ground carrying leaf
    clusters (all class bush) that fill its dome with gaps."""
    centre = np.array([0.0, 0.0, 0.45 * radius])
    axes = np.array([radius, radius, 0.8 * radius])
    sk = Skeleton(max(3, d.branch_sides - 1))
    stems = int(rng.integers(4, 7))
    aims = directions(
        rng.uniform(0.0, 2.0 * math.pi) + 2.0 * math.pi * np.arange(stems) / stems,
        rng.uniform(0.5, 1.2, stems),
    )
    for aim in aims:
        foot = np.array([0.0, 0.0, -0.05])
        tip = inside_ellipsoid((centre + aim * axes * 0.8)[None], centre, axes, 0.8)[0]
        sk.add(np.stack([foot, 0.5 * (foot + tip) + [0.0, 0.0, 0.1], tip]), [0.015, 0.01, 0.005], 1.0)
    volume = 4.0 / 3.0 * math.pi * axes.prod()
    count = leaf_count(BUSH_LEAF_AREA_DENSITY * volume, LEAF_SIZE["bush"])
    centres = sk.points_along(rng, count, 0.2) + rng.normal(0.0, 0.3 * radius, (count, 3))
    centres = inside_ellipsoid(centres, centre, axes)
    centres[:, 2] = np.maximum(centres[:, 2], 0.05)
    leaves = leaf_triangles(rng, centres, leaf_normals(rng, count, 0.3), LEAF_SIZE["bush"])
    return merge([sk.mesh(), leaves])


def blade_tuft(rng: np.random.Generator, height: float, spread: float) -> Mesh:
    """High grass as HIGH_GRASS_BLADES separate blades (shapes/foliage.blades)."""
    return blades(rng, height, spread, HIGH_GRASS_BLADES)
