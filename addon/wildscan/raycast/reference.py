"""Exact float64 ground truth for ray casting, by brute force (tests, benchmarks; no bpy).

`reference_hits` finds every ray's first hit over every triangle of a SceneGeometry,
O(rays x triangles); `check_hits` judges a backend's RayHits against it, allowing what
float32 backends legitimately differ on (hits within `edge_tol` of an edge) and
flagging leaks through shared edges and vertices.
"""

from __future__ import annotations

import numpy as np

from ..core.hits import RayHits
from .geometry import SceneGeometry
from .refine import prepare_rays

_REFERENCE_CHUNK = 512  # rays per block: keeps the (rays x triangles) arrays small


def _edge_frames(geometry: SceneGeometry):
    """Per triangle: plane (unit normal, offset) and, per edge, the in-plane unit inward
    normal with its offset, all in offset-local float64."""
    local = geometry.vertices - geometry.offset
    v = [local[geometry.faces[:, k]] for k in range(3)]
    normal = np.cross(v[1] - v[0], v[2] - v[0])
    length = np.linalg.norm(normal, axis=1)
    ok = length > 0
    normal = normal / np.where(ok, length, 1.0)[:, None]
    inward = []
    for k in range(3):
        a, b = v[k], v[(k + 1) % 3]
        m = np.cross(normal, b - a)
        m /= np.maximum(np.linalg.norm(m, axis=1), 1e-300)[:, None]
        inward.append((m, np.einsum("ij,ij->i", m, a)))
    return normal, np.einsum("ij,ij->i", normal, v[0]), inward, ok


def reference_hits(
    geometry: SceneGeometry, origins, directions, max_range: float, edge_tol: float = 1e-4
) -> dict:
    """Exact float64 first hits by brute force over every triangle, O(rays x triangles).

    For each ray and triangle the ray meets the triangle's plane at t; `depth` is how far
    inside the triangle (metres, in its plane) that point lies. A hit is *clear* when
    depth > edge_tol and *ambiguous* when |depth| <= edge_tol: a correct float32 backend may
    or may not report those. Returns a dict of (N,) arrays:
      distance, triangle        the first clear hit (inf, -1 when none)
      ambiguous_before          an ambiguous hit lies before (or at) the first clear one
    Use `check_hits` to judge a backend against it.
    """
    local, dirs = prepare_rays(origins, directions, geometry.offset)
    count = len(dirs)
    distance = np.full(count, np.inf)
    triangle = np.full(count, -1, dtype=np.int64)
    ambiguous_before = np.zeros(count, dtype=bool)
    if not geometry.triangle_count:
        return {"distance": distance, "triangle": triangle, "ambiguous_before": ambiguous_before}
    frames = _edge_frames(geometry)
    for start in range(0, count, _REFERENCE_CHUNK):
        sl = slice(start, start + _REFERENCE_CHUNK)
        t, depth, valid, _ = _plane_hits(frames, local[sl], dirs[sl], max_range)
        clear = valid & (depth > edge_tol)
        t_clear = np.where(clear, t, np.inf)
        first = np.argmin(t_clear, axis=1)
        rows = np.arange(len(first))
        best = t_clear[rows, first]
        distance[sl] = best
        triangle[sl] = np.where(np.isfinite(best), first, -1)
        amb = valid & (np.abs(depth) <= edge_tol) & (t <= best[:, None] + edge_tol)
        ambiguous_before[sl] = amb.any(axis=1)
    return {"distance": distance, "triangle": triangle, "ambiguous_before": ambiguous_before}


def _plane_hits(frames, local: np.ndarray, dirs: np.ndarray, max_range: float):
    """(t, depth, valid, front), each (rays, triangles); front: the ray meets the
    triangle's front (normal-facing) side."""
    normal, d, inward, ok = frames
    denom = dirs @ normal.T
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (d[None, :] - local @ normal.T) / denom
    valid = ok[None, :] & (np.abs(denom) > 1e-12) & (t > 0) & (t <= max_range)
    t = np.where(valid, t, np.inf)
    finite_t = np.where(valid, t, 0.0)
    depth = np.full(t.shape, np.inf)
    for m, off in inward:
        s = local @ m.T + finite_t * (dirs @ m.T) - off[None, :]
        depth = np.minimum(depth, s)
    return t, depth, valid, denom < 0


def check_hits(
    geometry: SceneGeometry,
    origins,
    directions,
    max_range: float,
    hits: RayHits,
    edge_tol: float = 1e-4,
    range_tol: float = 1e-4,
) -> np.ndarray:
    """Per ray, whether a backend's answer is correct within tolerances (bool (N,)).

    Correct means: the backend reports a surface (class, instance) that the exact ray
    meets within `range_tol` of the reported range, with nothing clearly hit before it;
    or it reports a miss and nothing is clearly hit. Triangles the ray meets within
    `edge_tol` of an edge may be reported or not (float32 backends legitimately differ
    there), except that a ray crossing a surface through a shared edge or vertex must
    stop there: going on to the surface behind, or to nothing, is a leak.
    """
    local, dirs = prepare_rays(origins, directions, geometry.offset)
    count = len(dirs)
    ok = np.zeros(count, dtype=bool)
    if not geometry.triangle_count:
        return ~hits.hit
    frames = _edge_frames(geometry)
    labels = geometry.class_id.astype(np.int64) * (1 << 32) + geometry.instance.astype(np.int64)
    hit_label = hits.class_id.astype(np.int64) * (1 << 32) + hits.instance.astype(np.int64)
    for start in range(0, count, _REFERENCE_CHUNK):
        sl = slice(start, start + _REFERENCE_CHUNK)
        with np.errstate(invalid="ignore"):  # inf - inf where neither side hit: compares False
            ok[sl] = _check_block(
                frames,
                labels,
                local[sl],
                dirs[sl],
                max_range,
                hits.distance[sl],
                hit_label[sl],
                edge_tol,
                range_tol,
            )
    return ok


def _check_block(frames, labels, local, dirs, max_range, t_b, label_b, edge_tol, range_tol):
    t, depth, valid, front = _plane_hits(frames, local, dirs, max_range + range_tol)
    clear = valid & (depth > edge_tol)
    maybe = valid & (depth >= -edge_tol)
    t_clear = np.where(clear, t, np.inf).min(axis=1)
    # a correct hit: a triangle the ray (at least ambiguously) meets, with the same label
    # and range, not behind the first clear hit
    match = maybe & (np.abs(t - t_b[:, None]) <= range_tol) & (labels[None, :] == label_b[:, None])
    good_hit = np.isfinite(t_b) & match.any(axis=1) & (t_b <= t_clear + range_tol)
    # a leak: the ray crosses a shared edge or vertex before the reported hit, i.e. meets
    # two or more triangles there ambiguously, all from the same side (a silhouette,
    # met from both sides, may be missed)
    amb_before = maybe & ~clear & (t < t_b[:, None] - range_tol)
    leaked = _crossing_covered(amb_before & front, t, range_tol)
    leaked |= _crossing_covered(amb_before & ~front, t, range_tol)
    good_miss = ~np.isfinite(t_b) & ~np.isfinite(t_clear)
    near_limit = ~np.isfinite(t_b) & (t_clear > max_range - range_tol)
    return (good_hit | good_miss | near_limit) & ~leaked


def _crossing_covered(amb_before: np.ndarray, t: np.ndarray, range_tol: float) -> np.ndarray:
    """Rays that pass ambiguously through two or more of the marked triangles at the same
    point (a shared edge or vertex)."""
    tt = np.where(amb_before, t, np.inf)
    order = np.sort(tt, axis=1)[:, :2] if tt.shape[1] >= 2 else np.full((len(tt), 2), np.inf)
    return np.isfinite(order[:, 1]) & (order[:, 1] - order[:, 0] <= range_tol)
