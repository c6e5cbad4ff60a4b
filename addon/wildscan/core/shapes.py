"""Few-polygon element meshes for the world builder (numpy only).

Every shape is a (vertices (V,3) float64, faces (F,3) int32) pair in the
element's local frame: origin on the ground at the element's foot, Z up, X the
element's heading. Shapes are built once per world as shared prototypes;
instances only move, turn and scale them.

Modelling rule: no more detail than the sensor can resolve (15 m range,
0.25 deg between beams: ~6.5 cm at 15 m) and nothing hidden inside something
else: a trunk or branch stops just inside its crown, a rock or bush loses the
faces that lie wholly below the ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .testworld_plan import box, merge, tube

Mesh = tuple[np.ndarray, np.ndarray]

__all__ = [
    "Mesh",
    "box",
    "merge",
    "tube",
    "lathe",
    "tapered_tube",
    "icosphere",
    "lumpy",
    "drop_buried",
    "tuft",
    "TreeShape",
    "conifer",
    "broadleaf",
    "birch",
    "TREE_KINDS",
    "bush",
    "rock",
    "table",
    "bench",
    "fence_section",
    "fence_post",
    "pole",
    "POLE_ATTACHMENTS",
    "catenary",
    "wire",
    "transform",
    "triangle_count",
]


def transform(mesh: Mesh, location=(0.0, 0.0, 0.0), yaw: float = 0.0, scale=(1.0, 1.0, 1.0)) -> np.ndarray:
    """World vertices of `mesh` scaled, turned by yaw (radians, CCW) and moved."""
    v = np.asarray(mesh[0], dtype=np.float64) * np.asarray(scale, dtype=np.float64)
    c, s = math.cos(yaw), math.sin(yaw)
    out = np.empty_like(v)
    out[:, 0] = c * v[:, 0] - s * v[:, 1] + location[0]
    out[:, 1] = s * v[:, 0] + c * v[:, 1] + location[1]
    out[:, 2] = v[:, 2] + location[2]
    return out


def triangle_count(mesh: Mesh) -> int:
    return int(len(mesh[1]))


# ---------------------------------------------------------------------------------------
# surfaces of revolution and tubes


def lathe(
    radii, heights, segments: int, cap_bottom: bool = False, cap_top: bool = False, phase: float = 0.0
) -> Mesh:
    """Revolve a profile (bottom to top) about Z. A zero radius at either end becomes a
    single apex vertex, so cones and closed crowns need no cap."""
    radii = np.asarray(radii, dtype=np.float64)
    heights = np.asarray(heights, dtype=np.float64)
    theta = phase + 2.0 * np.pi * np.arange(segments) / segments
    verts, faces = [], []
    ring_start = []
    n = 0
    for r, z in zip(radii, heights):
        ring_start.append(n)
        if r <= 0.0:
            verts.append([[0.0, 0.0, z]])
            n += 1
        else:
            verts.append(np.stack([r * np.cos(theta), r * np.sin(theta), np.full(segments, z)], -1))
            n += segments
    s = np.arange(segments)
    s1 = (s + 1) % segments
    for k in range(len(radii) - 1):
        a0, a1 = ring_start[k], ring_start[k + 1]
        lo_apex, hi_apex = radii[k] <= 0.0, radii[k + 1] <= 0.0
        if lo_apex and hi_apex:
            continue
        if lo_apex:
            faces.append(np.stack([np.full(segments, a0), a1 + s1, a1 + s], -1))
        elif hi_apex:
            faces.append(np.stack([a0 + s, a0 + s1, np.full(segments, a1)], -1))
        else:
            faces.append(np.stack([a0 + s, a0 + s1, a1 + s1], -1))
            faces.append(np.stack([a0 + s, a1 + s1, a1 + s], -1))
    v = np.concatenate(verts)
    if cap_bottom and radii[0] > 0.0:
        faces.append(np.stack([np.full(segments, len(v)), s1, s], -1))
        v = np.concatenate([v, [[0.0, 0.0, heights[0]]]])
    if cap_top and radii[-1] > 0.0:
        top = ring_start[-1]
        faces.append(np.stack([np.full(segments, len(v)), top + s, top + s1], -1))
        v = np.concatenate([v, [[0.0, 0.0, heights[-1]]]])
    return v, np.concatenate(faces).astype(np.int32)


def tapered_tube(path, radii, sides: int, cap_end: bool = True) -> Mesh:
    """A tube along a polyline whose radius varies per point (branches, trunks)."""
    path = np.asarray(path, dtype=np.float64)
    radii = np.asarray(radii, dtype=np.float64)
    verts, faces = tube(path, 1.0, sides, caps=False)
    centres = np.repeat(path, sides, axis=0)
    verts = centres + (verts - centres) * np.repeat(radii, sides)[:, None]
    if cap_end:
        last = (len(path) - 1) * sides
        s = np.arange(sides)
        cap = np.stack([np.full(sides, len(verts)), last + s, last + (s + 1) % sides], -1)
        verts = np.concatenate([verts, path[-1:]])
        faces = np.concatenate([faces, cap])
    return verts, faces.astype(np.int32)


def icosphere(subdivisions: int) -> Mesh:
    """Unit icosphere: 20 * 4^subdivisions triangles, all vertices on the sphere."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    v = np.array(
        [
            [-1, t, 0],
            [1, t, 0],
            [-1, -t, 0],
            [1, -t, 0],
            [0, -1, t],
            [0, 1, t],
            [0, -1, -t],
            [0, 1, -t],
            [t, 0, -1],
            [t, 0, 1],
            [-t, 0, -1],
            [-t, 0, 1],
        ],
        dtype=np.float64,
    )
    f = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inverse = np.unique(edges, axis=0, return_inverse=True)
        inverse = inverse.ravel()
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(v) + inverse.reshape(3, -1)  # midpoints of edges 01, 12, 20 per face
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        f = np.concatenate(
            [
                np.stack([a, m[0], m[2]], -1),
                np.stack([b, m[1], m[0]], -1),
                np.stack([c, m[2], m[1]], -1),
                np.stack([m[0], m[1], m[2]], -1),
            ]
        )
        v = np.concatenate([v, mid])
    return v, f.astype(np.int32)


def lumpy(mesh: Mesh, rng: np.random.Generator, amount: float, waves: int = 5) -> Mesh:
    """Displace a star-shaped mesh radially by a few smooth random waves (organic outlines
    without extra triangles)."""
    v = np.asarray(mesh[0], dtype=np.float64)
    r = np.linalg.norm(v, axis=1, keepdims=True)
    d = v / np.maximum(r, 1e-12)
    dirs = rng.normal(size=(waves, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    freq = rng.uniform(1.5, 3.5, waves)
    phase = rng.uniform(0, 2 * np.pi, waves)
    wave = np.sin(d @ dirs.T * freq + phase).sum(axis=1) / math.sqrt(waves)
    return v * (1.0 + amount * wave)[:, None], mesh[1]


def drop_buried(mesh: Mesh, z_ground: float = 0.0) -> Mesh:
    """Remove faces whose three corners are below the ground (nobody can see them)."""
    v, f = mesh
    keep = ~(v[f][:, :, 2] < z_ground).all(axis=1)
    f = f[keep]
    used = np.unique(f)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return v[used], remap[f].astype(np.int32)


def scaled(mesh: Mesh, sx: float, sy: float, sz: float, dz: float = 0.0) -> Mesh:
    return mesh[0] * [sx, sy, sz] + [0.0, 0.0, dz], mesh[1]


# ---------------------------------------------------------------------------------------
# grass


def tuft(rng: np.random.Generator, height: float, spread: float, planes: int, blades: int) -> Mesh:
    """A grass tuft: `planes` crossed vertical zig-zags of `blades` single-triangle blades.

    planes * blades triangles in all (e.g. 3 x 3 = 9): enough for the beams to
    see a tuft's height and width, nothing a 6 cm beam spacing could not see.
    """
    verts, faces = [], []
    n = 0
    for p in range(planes):
        angle = math.pi * p / planes + rng.uniform(-0.2, 0.2)
        c, s = math.cos(angle), math.sin(angle)
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


# ---------------------------------------------------------------------------------------
# trees: trunk and branches are one element, the crown another


@dataclass
class TreeShape:
    kind: str
    trunk: Mesh
    crown: Mesh
    height: float
    crown_radius: float
    trunk_radius: float


def _ellipsoid_entry(p0, p1, centre, axes) -> float:
    """Parameter t in [0,1] where segment p0->p1 enters the ellipsoid (1 if it never does)."""
    a = (np.asarray(p1) - p0) / axes
    b = (np.asarray(p0) - centre) / axes
    qa, qb, qc = a @ a, 2 * a @ b, b @ b - 1.0
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
    return TreeShape("conifer", trunk, crown, height, radius, trunk_r)


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
        target = centre + np.array([0.6 * rx * math.cos(a), 0.6 * rx * math.sin(a), -0.2 * rz])
        t = _ellipsoid_entry(start, target, centre, axes * 0.98)
        end = start + (target - start) * min(1.0, t + 0.3 / np.linalg.norm(target - start))
        mid = 0.5 * (start + end) + [0.0, 0.0, 0.15]
        parts.append(
            tapered_tube([start, mid, end], [trunk_r * 0.45, trunk_r * 0.33, trunk_r * 0.22], d.branch_sides)
        )
    crown = lumpy(icosphere(d.sphere_subdivisions), rng, 0.12)
    crown = (crown[0] * axes + centre, crown[1])
    return TreeShape("broadleaf", merge(parts), crown, height, rx, trunk_r)


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
        end = start + length * np.array([math.cos(a) * 0.85, math.sin(a) * 0.85, 0.5])
        parts.append(tapered_tube([start, end], [0.045, 0.02], d.branch_sides))
    t = np.linspace(0.0, 1.0, d.crown_rings + 2)
    r = radius * np.sin(np.pi * t) ** 0.8
    r[0] = r[-1] = 0.0
    crown = lathe(r, crown_base + t * (height - crown_base), d.crown_sides, phase=rng.uniform(0, 1))
    crown = lumpy(((crown[0] - [0, 0, (crown_base + height) / 2]), crown[1]), rng, 0.08)
    crown = (crown[0] + [0, 0, (crown_base + height) / 2], crown[1])
    return TreeShape("birch", merge(parts), crown, height, radius, trunk_r)


TREE_KINDS = {"conifer": conifer, "broadleaf": broadleaf, "birch": birch}


# ---------------------------------------------------------------------------------------
# bushes and rocks


def bush(rng: np.random.Generator, d) -> tuple[Mesh, float]:
    """A lumpy dome about 1.2 m wide and 0.9 m high at scale 1; returns (mesh, radius)."""
    radius = rng.uniform(0.55, 0.75)
    m = lumpy(icosphere(d.bush_subdivisions), rng, 0.18)
    m = scaled(m, radius, radius, radius * 0.8, dz=radius * 0.45)
    return drop_buried(m, -0.05), radius


def rock(rng: np.random.Generator, d) -> tuple[Mesh, float]:
    """A faceted stone about 1 m across at scale 1, a third sunk in the ground."""
    m = lumpy(icosphere(d.rock_subdivisions), rng, 0.22, waves=4)
    sy, sz = rng.uniform(0.7, 0.9), rng.uniform(0.45, 0.7)
    m = scaled(m, 0.5, 0.5 * sy, 0.5 * sz, dz=0.5 * sz * 0.4)
    return drop_buried(m, -0.05), 0.55


# ---------------------------------------------------------------------------------------
# park furniture and the power line


def table() -> Mesh:
    """Picnic table, 1.8 m x 0.8 m top at 0.75 m, heading along X."""
    parts = [box((0, 0, 0.75), (1.8, 0.8, 0.05))]
    for sx in (-0.75, 0.75):
        for sy in (-0.3, 0.3):
            parts.append(box((sx, sy, 0.31), (0.07, 0.07, 0.82)))
    return merge(parts)


def bench() -> Mesh:
    """Park bench, 1.6 m long, seat at 0.45 m, backrest on the -Y side."""
    parts = [box((0, 0, 0.45), (1.6, 0.42, 0.05)), box((0, -0.19, 0.75), (1.6, 0.05, 0.3))]
    for sx in (-0.7, 0.7):
        parts.append(box((sx, 0.15, 0.16), (0.06, 0.06, 0.52)))
        parts.append(box((sx, -0.19, 0.36), (0.06, 0.06, 0.92)))
    return merge(parts)


def fence_post() -> Mesh:
    return box((0, 0, 0.45), (0.1, 0.1, 1.3))


def fence_section(length: float) -> Mesh:
    """A post at x=0 and two rails reaching the next section's post at x=length."""
    return merge(
        [
            fence_post(),
            box((length / 2, 0, 0.45), (length - 0.1, 0.04, 0.1)),
            box((length / 2, 0, 0.9), (length - 0.1, 0.04, 0.1)),
        ]
    )


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
    """Points of the catenary z = a cosh((s - s0)/a) + c hanging from p0 to p1 whose lowest
    point lies `sag` below the chord midpoint (for level ends). (samples, 3)."""
    p0 = np.asarray(p0, dtype=np.float64)
    p1 = np.asarray(p1, dtype=np.float64)
    span = float(np.hypot(*(p1[:2] - p0[:2])))
    a = catenary_parameter(span, sag)
    dz = p1[2] - p0[2]
    # cosh(u + L/a) - cosh(u) = dz / a  with u = -s0/a:  2 sinh(u + L/2a) sinh(L/2a) = dz / a
    u = math.asinh(dz / (2 * a * math.sinh(span / (2 * a)))) - span / (2 * a)
    c = p0[2] - a * math.cosh(u)
    s = np.linspace(0.0, span, samples)
    z = a * np.cosh(u + s / a) + c
    t = s / span
    xy = p0[:2] + np.outer(t, p1[:2] - p0[:2])
    return np.column_stack([xy, z])


def catenary_parameter(span: float, sag: float) -> float:
    """The a of a level-ended catenary with this span and mid-span sag (bisection)."""
    lo, hi = 1e-3, 1e6
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if mid * (math.cosh(span / (2 * mid)) - 1.0) > sag:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


def wire(path, radius: float, sides: int) -> Mesh:
    return tube(path, radius, sides, caps=False)
