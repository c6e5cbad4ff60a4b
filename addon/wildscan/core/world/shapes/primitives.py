"""Mesh primitives and the operations on them, shared by both worlds (numpy only).

Each returns a (vertices (V,3) float64, faces (F,3) int32) pair, all triangles
wound counter-clockwise seen from outside.
"""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm

Mesh = tuple[np.ndarray, np.ndarray]

# ---------------------------------------------------------------------------------------
# solids and surfaces


def _faces(rows) -> np.ndarray:
    return np.asarray(rows, dtype=np.int32).reshape(-1, 3)


def merge(parts: list[Mesh]) -> Mesh:
    """One mesh from several, offsetting face indices."""
    verts, faces, offset = [], [], 0
    for v, f in parts:
        verts.append(np.asarray(v, dtype=np.float64))
        faces.append(np.asarray(f, dtype=np.int32) + offset)
        offset += len(v)
    return np.concatenate(verts), np.concatenate(faces)


def box(center=(0.0, 0.0, 0.0), size=(1.0, 1.0, 1.0)) -> Mesh:
    """Axis-aligned box."""
    c = np.asarray(center, dtype=np.float64)
    h = np.asarray(size, dtype=np.float64) / 2.0
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], dtype=np.float64)
    # vertex k = x + 2y + 4z with each bit 0 for -1, 1 for +1
    quads = [
        (0, 2, 3, 1),  # -z
        (4, 5, 7, 6),  # +z
        (0, 1, 5, 4),  # -y
        (2, 6, 7, 3),  # +y
        (0, 4, 6, 2),  # -x
        (1, 3, 7, 5),  # +x
    ]
    tris = [t for a, b, cc, d in quads for t in ((a, b, cc), (a, cc, d))]
    return c + corners * h, _faces(tris)


def _ring_frames(path: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tangent and two normals per path point; the reference axis is world Z unless the
    path runs near-vertical, so a planar curve gets a twist-free frame."""
    tangent = np.gradient(path, axis=0)
    tangent /= dm.norm(tangent)[:, None]
    ref = np.where(np.abs(tangent[:, 2:3]) > 0.9, [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    normal = dm.cross(ref, tangent)
    normal /= dm.norm(normal)[:, None]
    binormal = dm.cross(tangent, normal)
    return tangent, normal, binormal


def tube(path, radius: float, sides: int = 8, caps: bool = True, angle0: float = 0.0) -> Mesh:
    """Closed tube of `sides` facets along a polyline (K,3), K >= 2."""
    path = np.asarray(path, dtype=np.float64)
    k = len(path)
    _, normal, binormal = _ring_frames(path)
    theta = angle0 + 2.0 * np.pi * np.arange(sides) / sides
    sin, cos = dm.sincos(theta)
    ring = cos[None, :, None] * normal[:, None, :] + sin[None, :, None] * binormal[:, None, :]
    verts = (path[:, None, :] + radius * ring).reshape(-1, 3)
    s = np.arange(sides)
    a = np.arange(k - 1)[:, None] * sides + s[None, :]
    b = np.arange(k - 1)[:, None] * sides + (s[None, :] + 1) % sides
    c, d = b + sides, a + sides
    faces = [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    if caps:
        start, end = len(verts), len(verts) + 1
        verts = np.concatenate([verts, path[:1], path[-1:]])
        faces.append(np.stack([np.full(sides, start), (s + 1) % sides, s], -1))
        last = (k - 1) * sides
        faces.append(np.stack([np.full(sides, end), last + s, last + (s + 1) % sides], -1))
    return verts, np.concatenate(faces).astype(np.int32)


def cylinder(radius: float, height: float, sides: int = 12, base=(0.0, 0.0, 0.0)) -> Mesh:
    """Vertical capped cylinder standing on `base`."""
    base = np.asarray(base, dtype=np.float64)
    return tube([base, base + [0.0, 0.0, height]], radius, sides)


def beam(p0, p1, width: float, sides: int = 4) -> Mesh:
    """Square bar (sides=4) of the given width between two points."""
    return tube([p0, p1], width / np.sqrt(2.0), sides, angle0=np.pi / 4)


def cone(radius: float, height: float, sides: int = 12, base=(0.0, 0.0, 0.0)) -> Mesh:
    """Vertical cone with its base disc on `base`."""
    base = np.asarray(base, dtype=np.float64)
    sin, cos = dm.sincos(2.0 * np.pi * np.arange(sides) / sides)
    ring = base + np.stack([radius * cos, radius * sin, np.zeros(sides)], -1)
    verts = np.concatenate([ring, [base + [0.0, 0.0, height]], [base]])
    s = np.arange(sides)
    apex, centre = sides, sides + 1
    side = np.stack([s, (s + 1) % sides, np.full(sides, apex)], -1)
    cap = np.stack([np.full(sides, centre), (s + 1) % sides, s], -1)
    return verts, np.concatenate([side, cap]).astype(np.int32)


def uv_sphere(radius: float = 1.0, rings: int = 8, segments: int = 12, center=(0.0, 0.0, 0.0)) -> Mesh:
    """UV sphere with single pole vertices (so per-vertex noise keeps it closed)."""
    sin_p, cos_p = dm.sincos(np.pi * np.arange(1, rings) / rings)  # polar angle of the inner rings
    sin_t, cos_t = dm.sincos(2.0 * np.pi * np.arange(segments) / segments)
    ring_pts = np.stack(
        [
            sin_p[:, None] * cos_t[None, :],
            sin_p[:, None] * sin_t[None, :],
            np.broadcast_to(cos_p[:, None], (rings - 1, segments)),
        ],
        -1,
    ).reshape(-1, 3)
    verts = np.concatenate([[[0.0, 0.0, 1.0]], ring_pts, [[0.0, 0.0, -1.0]]])
    top, bottom = 0, len(verts) - 1
    s = np.arange(segments)
    faces = [np.stack([np.full(segments, top), 1 + s, 1 + (s + 1) % segments], -1)]
    for r in range(rings - 2):
        a = 1 + r * segments + s
        b = 1 + r * segments + (s + 1) % segments
        c, d = b + segments, a + segments
        faces += [np.stack([a, d, c], -1), np.stack([a, c, b], -1)]
    last = 1 + (rings - 2) * segments
    faces.append(np.stack([np.full(segments, bottom), last + (s + 1) % segments, last + s], -1))
    return np.asarray(center, dtype=np.float64) + radius * verts, np.concatenate(faces).astype(np.int32)


def grid_heightfield(xs, ys, heights) -> Mesh:
    """Triangulated heightfield: heights[j, i] at (xs[i], ys[j]); each cell is split along
    its (i, j)-(i+1, j+1) diagonal (the triangles `heightfield.interpolate` interpolates)."""
    xs, ys = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    heights = np.asarray(heights, dtype=np.float64)
    nx, ny = len(xs), len(ys)
    gx, gy = np.meshgrid(xs, ys)
    verts = np.stack([gx, gy, heights], -1).reshape(-1, 3)
    v00 = (np.arange(ny - 1)[:, None] * nx + np.arange(nx - 1)[None, :]).ravel()
    v10, v01 = v00 + 1, v00 + nx
    v11 = v01 + 1
    faces = np.concatenate([np.stack([v00, v10, v11], -1), np.stack([v00, v11, v01], -1)])
    return verts, faces.astype(np.int32)


def disc(radius: float, z: float, center=(0.0, 0.0), sides: int = 48) -> Mesh:
    """Flat horizontal disc facing up."""
    sin, cos = dm.sincos(2.0 * np.pi * np.arange(sides) / sides)
    ring = np.stack([center[0] + radius * cos, center[1] + radius * sin, np.full(sides, z)], -1)
    verts = np.concatenate([ring, [[center[0], center[1], z]]])
    s = np.arange(sides)
    return verts, np.stack([np.full(sides, sides), s, (s + 1) % sides], -1).astype(np.int32)


def lathe(
    radii, heights, segments: int, cap_bottom: bool = False, cap_top: bool = False, phase: float = 0.0
) -> Mesh:
    """Revolve a profile (bottom to top) about Z. A zero radius at either end becomes a
    single apex vertex, so cones and closed crowns need no cap."""
    radii = np.asarray(radii, dtype=np.float64)
    heights = np.asarray(heights, dtype=np.float64)
    sin, cos = dm.sincos(phase + 2.0 * np.pi * np.arange(segments) / segments)
    verts, faces = [], []
    ring_start = []
    n = 0
    for r, z in zip(radii, heights):
        ring_start.append(n)
        if r <= 0.0:
            verts.append([[0.0, 0.0, z]])
            n += 1
        else:
            verts.append(np.stack([r * cos, r * sin, np.full(segments, z)], -1))
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
    v /= dm.norm(v)[:, None]
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inverse = np.unique(edges, axis=0, return_inverse=True)
        inverse = inverse.ravel()
        mid = v[uniq[:, 0]] + v[uniq[:, 1]]
        mid /= dm.norm(mid)[:, None]
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


# ---------------------------------------------------------------------------------------
# operations on meshes


def lumpy(mesh: Mesh, rng: np.random.Generator, amount: float, waves: int = 5) -> Mesh:
    """Displace a star-shaped mesh radially by a few smooth random waves (organic outlines
    without extra triangles)."""
    v = np.asarray(mesh[0], dtype=np.float64)
    d = v / np.maximum(dm.norm(v), 1e-12)[:, None]
    dirs = rng.normal(size=(waves, 3))
    dirs /= dm.norm(dirs)[:, None]
    freq = rng.uniform(1.5, 3.5, waves)
    phase = rng.uniform(0, 2 * np.pi, waves)
    wave = np.zeros(len(v))
    for k in range(waves):  # one wave at a time, in order: the sum's order is fixed
        wave += dm.sin(dm.dot3(d, dirs[k]) * freq[k] + phase[k])
    return v * (1.0 + amount * (wave / math.sqrt(waves)))[:, None], mesh[1]


def drop_buried(mesh: Mesh, z_ground: float = 0.0) -> Mesh:
    """Remove faces whose three corners are below the ground (nobody can see them)."""
    v, f = mesh
    return faces_subset(mesh, ~(v[f][:, :, 2] < z_ground).all(axis=1))


def faces_subset(mesh: Mesh, keep: np.ndarray) -> Mesh:
    """The faces of `mesh` where `keep` holds, with only the vertices they use (in their
    order in `mesh`)."""
    v, f = mesh
    f = f[keep]
    used = np.unique(f)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return v[used], remap[f].astype(np.int32)


def scaled(mesh: Mesh, sx: float, sy: float, sz: float, dz: float = 0.0) -> Mesh:
    return mesh[0] * [sx, sy, sz] + [0.0, 0.0, dz], mesh[1]


def transform(mesh: Mesh, location=(0.0, 0.0, 0.0), yaw: float = 0.0, scale=(1.0, 1.0, 1.0)) -> np.ndarray:
    """World vertices of `mesh` scaled, turned by yaw (radians, CCW) and moved."""
    v = np.asarray(mesh[0], dtype=np.float64) * np.asarray(scale, dtype=np.float64)
    s, c = dm.sincos(yaw)
    out = np.empty_like(v)
    out[:, 0] = c * v[:, 0] - s * v[:, 1] + location[0]
    out[:, 1] = s * v[:, 0] + c * v[:, 1] + location[1]
    out[:, 2] = v[:, 2] + location[2]
    return out


def triangle_count(mesh: Mesh) -> int:
    return int(len(mesh[1]))


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Volume enclosed by a closed triangle mesh; positive when faces wind outward."""
    v = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    return float(dm.dot3(v[:, 0], dm.cross(v[:, 1], v[:, 2])).sum() / 6.0)


def rotate_z(vertices: np.ndarray, yaw: float, about=(0.0, 0.0)) -> np.ndarray:
    s, c = dm.sincos(yaw)
    out = np.array(vertices, dtype=np.float64)
    x, y = out[:, 0] - about[0], out[:, 1] - about[1]
    out[:, 0], out[:, 1] = about[0] + c * x - s * y, about[1] + s * x + c * y
    return out
