"""How porous the vegetation is, measured by ray casting (no Blender): the share of horizontal
beams that pass through a crown, and the share of the sky seen from under the forest canopy.

Crown gap fraction. Each tree prototype (trunk and branches with its crown, as a world
stands it) is crossed by a grid of horizontal rays CROWN_RAY_SPACING apart. How much
crown a ray crosses is measured on the same tree's solid crown (the envelope the porous
one was grown in: the world planned with `vegetation="solid"` has it under the same
key); the gap fraction "through a 3 m crown" is the share of the rays crossing 2.5-3.5 m
of envelope that hit nothing at all (no leaf, branch or trunk).

Sky fraction. From points on a grid over the forest zone, SKY_EYE_HEIGHT above the
ground, rays uniform over the solid angle of the sky up to SKY_ZENITH_MAX from the
zenith (the field hemispherical photographs are read over); the share that escape. It
is the complement of canopy closure (Jennings et al., Forestry 72(1), 1999).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.backend import RayBackend

CROWN_RAY_SPACING = 0.03  # m between the horizontal rays of the crown grid
CHORD_BAND = (2.5, 3.5)  # m of crown envelope a "3 m crown" ray crosses
SKY_EYE_HEIGHT = 1.0  # m above the ground
SKY_ZENITH_MAX_DEG = 60.0
SKY_GRID_SPACING = 6.0  # m between sky points
SKY_RAYS_PER_POINT = 4000
SKY_REACH = 60.0  # m: farther than any crown above the forest reaches


def _backend(vertices: np.ndarray, faces: np.ndarray) -> RayBackend:
    from ..raycast.geometry import from_triangles
    from ..raycast.select import make_backend

    return make_backend("auto", geometry=from_triangles(vertices[faces]), notify=None)


def _tree_triangles(plan, key: str) -> tuple[np.ndarray, np.ndarray]:
    from ..core.world.shapes.primitives import merge

    parts = [plan.prototypes[f"tree_{key}_{part}"] for part in ("trunk", "crown")]
    return merge([(p.vertices, p.faces) for p in parts])


def _chords(envelope, origins: np.ndarray, direction: np.ndarray, reach: float) -> np.ndarray:
    """Length of each ray's path through a closed envelope (0 where it misses): from its
    entry seen from the front to its exit seen from the back."""
    front = envelope.cast(origins, np.broadcast_to(direction, origins.shape), reach).distance
    back_origins = origins + reach * direction
    back = envelope.cast(back_origins, np.broadcast_to(-direction, origins.shape), reach).distance
    chord = reach - front - back
    return np.where(np.isfinite(front) & np.isfinite(back), np.maximum(chord, 0.0), 0.0)


def crown_gap_fractions(seed: int = 0, detail: str = "default") -> list[dict]:
    """Per tree prototype (kind and variant): rays crossing 2.5-3.5 m of crown and the share
    of them that pass, and the same over every ray crossing any crown (see module docstring)."""
    from ..core.world import plan_world

    porous = plan_world(seed, detail)
    solid = plan_world(seed, detail, vegetation="solid")
    rows = []
    for key in sorted({k[len("tree_") : -len("_crown")] for k in porous.prototypes if k.endswith("_crown")}):
        env = solid.prototypes[f"tree_{key}_crown"]
        lo, hi = env.vertices.min(axis=0), env.vertices.max(axis=0)
        reach = float(hi[0] - lo[0]) + 2.0
        ys = np.arange(lo[1], hi[1], CROWN_RAY_SPACING)
        zs = np.arange(lo[2], hi[2], CROWN_RAY_SPACING)
        gy, gz = np.meshgrid(ys, zs)
        origins = np.stack([np.full(gy.size, lo[0] - 1.0), gy.ravel(), gz.ravel()], -1)
        direction = np.array([1.0, 0.0, 0.0])
        chord = _chords(_backend(env.vertices, env.faces), origins, direction, reach)
        tree = _backend(*_tree_triangles(porous, key))
        passed = ~tree.cast(origins, np.broadcast_to(direction, origins.shape), reach).hit
        band = (chord >= CHORD_BAND[0]) & (chord <= CHORD_BAND[1])
        crossing = chord > 0.5
        rows.append(
            {
                "tree": key,
                "rays_3m": int(band.sum()),
                "gap_3m": float(passed[band].mean()) if band.any() else math.nan,
                "rays_crown": int(crossing.sum()),
                "gap_crown": float(passed[crossing].mean()) if crossing.any() else math.nan,
            }
        )
    return rows


def _sky_directions(count: int, zenith_max_deg: float, rng: np.random.Generator) -> np.ndarray:
    """Unit directions uniform over the solid angle within zenith_max of straight up."""
    cos_max = math.cos(math.radians(zenith_max_deg))
    cz = rng.uniform(cos_max, 1.0, count)
    a = rng.uniform(0.0, 2.0 * math.pi, count)
    s = np.sqrt(1.0 - cz * cz)
    return np.stack([s * np.cos(a), s * np.sin(a), cz], -1)


def sky_fraction(plan, geometry, zone: str = "forest", seed: int = 0) -> dict:
    """The share of the sky seen from under the canopy of `zone` (see module docstring):
    mean over the points, with the 10th and 90th percentiles of the points' own shares."""
    from ..raycast.select import make_backend

    x0, x1, y0, y1 = plan.layout.cells[zone]
    gx, gy = np.meshgrid(
        np.arange(x0 + 3.0, x1 - 3.0, SKY_GRID_SPACING), np.arange(y0 + 3.0, y1 - 3.0, SKY_GRID_SPACING)
    )
    xs, ys = gx.ravel(), gy.ravel()
    dry = ~plan.in_water(xs, ys)
    xs, ys = xs[dry], ys[dry]
    rng = np.random.default_rng(seed)
    backend = make_backend("auto", geometry=geometry, notify=None)
    shares = []
    for x, y in zip(xs, ys):
        eye = np.array([x, y, float(plan.ground(x, y)) + SKY_EYE_HEIGHT])
        dirs = _sky_directions(SKY_RAYS_PER_POINT, SKY_ZENITH_MAX_DEG, rng)
        shares.append(float((~backend.cast(eye, dirs, SKY_REACH).hit).mean()))
    shares = np.asarray(shares)
    return {
        "zone": zone,
        "points": len(shares),
        "sky": float(shares.mean()),
        "p10": float(np.percentile(shares, 10)),
        "p90": float(np.percentile(shares, 90)),
    }
