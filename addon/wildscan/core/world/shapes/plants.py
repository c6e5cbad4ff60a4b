"""Bushes and grass tufts."""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from .primitives import Mesh, drop_buried, icosphere, lumpy, scaled


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
