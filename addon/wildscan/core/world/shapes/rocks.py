"""Rocks."""

from __future__ import annotations

import numpy as np

from .primitives import Mesh, drop_buried, icosphere, lumpy, scaled


def rock(rng: np.random.Generator, d) -> tuple[Mesh, float]:
    """A faceted stone about 1 m across at scale 1, a third sunk in the ground."""
    m = lumpy(icosphere(d.rock_subdivisions), rng, 0.22, waves=4)
    sy, sz = rng.uniform(0.7, 0.9), rng.uniform(0.45, 0.7)
    m = scaled(m, 0.5, 0.5 * sy, 0.5 * sz, dz=0.5 * sz * 0.4)
    return drop_buried(m, -0.05), 0.55
