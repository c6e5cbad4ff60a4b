"""The power line: poles with a crossarm, and wires hanging between them as catenaries."""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from .primitives import Mesh, box, lathe, merge, tube

POLE_HEIGHT = 9.0
CROSSARM_Z = 8.6
# Where the three wires hang, in the pole's frame (the line runs along local X).
POLE_ATTACHMENTS = np.array(
    [[0.0, -0.9, CROSSARM_Z + 0.06], [0.0, 0.9, CROSSARM_Z + 0.06], [0.0, 0.0, POLE_HEIGHT]]
)


def pole(d) -> Mesh:
    """Wooden power-line pole with a crossarm across the line (local Y)."""
    shaft = lathe([0.14, 0.13, 0.1], [-0.5, 0.0, POLE_HEIGHT], d.trunk_sides, cap_top=True)
    arm = box((0.0, 0.0, CROSSARM_Z), (0.1, 2.0, 0.12))
    return merge([shaft, arm])


def catenary(p0, p1, sag: float, samples: int) -> np.ndarray:
    """Points of the catenary hanging from p0 to p1 whose lowest point lies `sag` below the
    chord midpoint (for level ends). (samples, 3)."""
    p0 = np.asarray(p0, dtype=np.float64)
    p1 = np.asarray(p1, dtype=np.float64)
    span = float(dm.hypot(*(p1[:2] - p0[:2])))
    return catenary_points(p0, p1, catenary_parameter(span, sag), samples)


def catenary_points(p0, p1, a: float, samples: int) -> np.ndarray:
    """Points of the catenary z = a cosh((s - s0)/a) + c through p0 and p1, s the horizontal
    distance from p0 and `a` (m) its parameter: the larger, the tauter. (samples, 3)."""
    p0 = np.asarray(p0, dtype=np.float64)
    p1 = np.asarray(p1, dtype=np.float64)
    span = float(dm.hypot(*(p1[:2] - p0[:2])))
    dz = float(p1[2] - p0[2])
    # cosh(u + L/a) - cosh(u) = dz / a  with u = -s0/a:  2 sinh(u + L/2a) sinh(L/2a) = dz / a
    u = dm.arcsinh(dz / (2 * a * dm.sinh(span / (2 * a)))) - span / (2 * a)
    c = float(p0[2]) - a * dm.cosh(u)
    s = np.linspace(0.0, span, samples)
    z = a * dm.cosh(u + s / a) + c
    t = s / span
    xy = p0[:2] + np.outer(t, p1[:2] - p0[:2])
    return np.column_stack([xy, z])


def catenary_parameter(span: float, sag: float) -> float:
    """The a of a level-ended catenary with this span and mid-span sag (bisection)."""
    lo, hi = 1e-3, 1e6
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if mid * (dm.cosh(span / (2 * mid)) - 1.0) > sag:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


def wire(path, radius: float, sides: int) -> Mesh:
    return tube(path, radius, sides, caps=False)
