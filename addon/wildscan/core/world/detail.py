"""Detail levels: how finely each shape is modelled (numpy only).

The world's layout and elements are the same at every level; only how finely
each shape is modelled changes. Errors are against the smooth shape a mesh
stands for: model_errors works them out for every shape, fit_grid measures the
terrain's at 100,000 random points, and `wildscan bench --suite world` prints both with
the triangle counts and build times (docs/benchmarks.md).

Terrain tolerances are 15, 5 and 2 cm (fit_grid keeps its sampled max within
75 % of them, because random samples miss the worst spot between them):
default is about three times the sensor's 1.5 cm range noise, high about the
noise itself. The high level's 0.1 m minimum grid spacing is what stops its fit
around the steepest basin walls. Repeated elements share meshes at every level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..checks import one_of
from .shapes.powerline import catenary_parameter
from .shapes.primitives import icosphere


@dataclass(frozen=True)
class DetailLevel:
    name: str
    terrain_tolerance: float  # m, max height error of the terrain grid vs the analytic field
    trunk_sides: int
    branch_sides: int
    crown_sides: int
    crown_rings: int
    sphere_subdivisions: int
    bush_subdivisions: int
    rock_subdivisions: int
    tuft_planes: int
    tuft_blades: int
    wire_sides: int
    wire_step: float  # m between catenary samples
    trail_step: float  # m between trail cross-sections
    trail_across: int  # vertices across the trail


DETAILS: dict[str, DetailLevel] = {
    "low": DetailLevel("low", 0.15, 5, 3, 6, 5, 1, 1, 1, 2, 2, 3, 4.0, 3.0, 3),
    "default": DetailLevel("default", 0.05, 7, 4, 9, 7, 2, 1, 1, 3, 3, 4, 2.0, 1.5, 3),
    "high": DetailLevel("high", 0.02, 10, 6, 14, 10, 3, 2, 2, 4, 4, 6, 1.0, 0.75, 5),
}


def detail_level(name: str) -> DetailLevel:
    if name not in DETAILS:
        one_of(name, "detail", DETAILS)
    return DETAILS[name]


def model_errors(d: DetailLevel) -> dict[str, float]:
    """How far each level's shapes are from the smooth shapes they stand for, metres, for
    reference sizes: a 3 m round crown (icosphere facets), a 0.3 m trunk (polygon sides),
    a 17 m wire span sagging 3 % (catenary chords). The terrain's is measured by fit_grid."""
    v, f = icosphere(d.sphere_subdivisions)
    n = dm.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    plane = np.abs(dm.dot3(n / dm.norm(n)[:, None], v[f[:, 0]]))
    a = catenary_parameter(17.0, 0.03 * 17.0)
    return {
        "crown_3m": float(3.0 * (1.0 - plane.min())),
        "trunk_0.3m": 0.3 * (1.0 - dm.cos(math.pi / d.trunk_sides)),
        "wire_chord": d.wire_step * d.wire_step / (8.0 * a),
        "terrain_tolerance": d.terrain_tolerance,
    }
