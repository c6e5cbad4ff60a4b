"""Suite "primitives": range error of every backend against analytic ground truth on a
tilted plane, a box, a UV-sphere polyhedron and a 48-sided prism, whose intersections are
computed in closed form (float64, from their facet planes, never from triangles)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .config import BENCH_COLLECTION, RANGE_TOLERANCE, REFERENCE, BenchConfig
from .measure import bench_scene, fast_backend, reference_backend, timed
from .report import Report, backend_title, fmt_s, metres, text_table

# =============================================================================================
# analytic primitives


@dataclass
class Solid:
    """A convex primitive: mesh for Blender plus its exact facet planes for the truth.

    Closed solids are the intersection of their facet half-spaces (outward normal n,
    n.x <= d inside). A flat one (the plane) is one polygon: its plane, and in-plane
    edge half-planes (inward m, m.x >= e)."""

    name: str
    wildscan_class: str
    instance: int
    vertices: np.ndarray
    polygons: list
    flat: bool = False
    normals: np.ndarray = field(init=False)
    offsets: np.ndarray = field(init=False)
    center: np.ndarray = field(init=False)
    radius: float = field(init=False)

    def __post_init__(self) -> None:
        v = self.vertices
        normals, offsets = [], []
        for poly in self.polygons:
            p = v[np.asarray(poly)]
            n = np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)  # Newell: exact for planar polygons
            n /= np.linalg.norm(n)
            normals.append(n)
            offsets.append(float(np.mean(p @ n)))
        self.normals, self.offsets = np.array(normals), np.array(offsets)
        if not self.flat:  # orient outward: the centroid is inside
            inside = v.mean(axis=0)
            flip = self.normals @ inside > self.offsets
            self.normals[flip] *= -1
            self.offsets[flip] *= -1
        self.center = v.mean(axis=0)
        self.radius = float(np.linalg.norm(v - self.center, axis=1).max())

    def triangles(self) -> np.ndarray:
        return np.array(
            [(poly[0], poly[k], poly[k + 1]) for poly in self.polygons for k in range(1, len(poly) - 1)]
        )

    def first_hit(self, origins: np.ndarray, dirs: np.ndarray, grow: float = 0.0) -> np.ndarray:
        """Distance to the solid along each ray (inf: miss), with every face moved out by
        `grow` metres (negative: in), in closed form from the planes."""
        t = np.full(len(dirs), np.inf)
        near = self._near(origins, dirs, abs(grow))
        if not near.any():
            return t
        o, d = origins[near], dirs[near]
        t[near] = self._flat_hit(o, d, grow) if self.flat else self._convex_hit(o, d, grow)
        return t

    def _near(self, origins, dirs, grow):
        w = self.center - origins
        along = np.einsum("ij,ij->i", w, dirs)
        gap2 = np.einsum("ij,ij->i", w, w) - along**2
        r = self.radius + grow + 1e-6
        return (gap2 <= r * r) & (along > -r)

    def _convex_hit(self, o, d, grow):
        nd = d @ self.normals.T
        room = (self.offsets + grow)[None, :] - o @ self.normals.T  # >= 0: inside that face
        with np.errstate(divide="ignore", invalid="ignore"):
            t = room / nd
        t_in = np.where(nd < 0, t, -np.inf).max(axis=1)
        t_out = np.where(nd > 0, t, np.inf).min(axis=1)
        outside_parallel = ((nd == 0) & (room < 0)).any(axis=1)
        hit = (t_in <= t_out) & (t_in > 0) & ~outside_parallel
        return np.where(hit, t_in, np.inf)

    def _flat_hit(self, o, d, grow):
        n, off = self.normals[0], self.offsets[0]
        nd = d @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (off - o @ n) / nd
        p = o + d * np.where(np.isfinite(t), t, 0.0)[:, None]
        ring = self.vertices[np.asarray(self.polygons[0])]
        inside = np.ones(len(d), dtype=bool)
        for a, b in zip(ring, np.roll(ring, -1, axis=0)):
            m = np.cross(n, b - a)
            m /= np.linalg.norm(m)
            if (ring.mean(axis=0) - a) @ m < 0:
                m = -m
            inside &= (p - a) @ m >= -grow
        return np.where(np.isfinite(t) & (t > 0) & inside, t, np.inf)


def _rotation(yaw: float, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    cz, sz, cy, sy, cx, sx = (
        math.cos(yaw),
        math.sin(yaw),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(roll),
        math.sin(roll),
    )
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1.0]])
    ry = np.array([[cy, 0, sy], [0, 1.0, 0], [-sy, 0, cy]])
    rx = np.array([[1.0, 0, 0], [0, cx, -sx], [0, sx, cx]])
    return rz @ ry @ rx


def primitive_solids() -> list[Solid]:
    """A tilted plane under a rotated box, a UV-sphere polyhedron (16 x 32) and a 48-sided
    prism, none touching another, all within reach of ANALYTIC_ORIGINS."""
    n = np.array([-0.06, 0.04, 1.0]) / np.linalg.norm([-0.06, 0.04, 1.0])
    u = np.cross([0.0, 1.0, 0.0], n)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    c = np.array([0.0, 0.0, -0.2])
    plane = c + 30.0 * np.array([a * u + b * v for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])

    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float) * [
        1.0,
        0.5,
        0.75,
    ]
    box = corners @ _rotation(0.7, 0.25, 0.1).T + [4.0, -3.0, 1.6]
    box_faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]

    rings, segs, r = 16, 32, 1.5
    polar = np.pi * np.arange(1, rings) / rings
    az = 2 * np.pi * np.arange(segs) / segs
    ring_pts = np.stack(
        [
            np.outer(np.sin(polar), np.cos(az)),
            np.outer(np.sin(polar), np.sin(az)),
            np.outer(np.cos(polar), np.ones(segs)),
        ],
        -1,
    ).reshape(-1, 3)
    sphere = r * np.concatenate([[[0, 0, 1.0]], ring_pts, [[0, 0, -1.0]]]) + [-4.0, 3.5, 2.2]
    bottom = len(sphere) - 1
    sphere_faces = [(0, 1 + s, 1 + (s + 1) % segs) for s in range(segs)]
    for k in range(rings - 2):
        for s in range(segs):
            a, b = 1 + k * segs + s, 1 + k * segs + (s + 1) % segs
            sphere_faces.append((a, a + segs, b + segs, b))
    last = 1 + (rings - 2) * segs
    sphere_faces += [(bottom, last + (s + 1) % segs, last + s) for s in range(segs)]

    sides, rc, h = 48, 0.6, 3.0
    ang = 2 * np.pi * np.arange(sides) / sides
    circle = np.column_stack([rc * np.cos(ang), rc * np.sin(ang)])
    prism = np.concatenate(
        [np.column_stack([circle, np.zeros(sides)]), np.column_stack([circle, np.full(sides, h)])]
    )
    prism += [3.5, 4.0, 0.8]
    prism_faces = [(s, (s + 1) % sides, sides + (s + 1) % sides, sides + s) for s in range(sides)]
    prism_faces += [tuple(range(sides - 1, -1, -1)), tuple(range(sides, 2 * sides))]

    return [
        Solid("bench plane", "terrain", 1, plane, [(0, 1, 2, 3)], flat=True),
        Solid("bench box", "rock", 2, box, box_faces),
        Solid("bench sphere", "bush", 3, sphere, sphere_faces),
        Solid("bench prism", "trunk", 4, prism, prism_faces),
    ]


ANALYTIC_ORIGINS = ((0.0, 0.0, 1.6, 0.0), (1.0, -1.5, 2.5, 37.0), (-1.5, 0.5, 1.0, 211.0))  # x, y, z, yaw deg
ANALYTIC_RANGE = 25.0


def analytic_rays(rh_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(origins (N,3), unit directions (N,3)): the scan pattern of r_h from each origin,
    turned by its yaw and tipped 7 deg so no beam runs along a face by symmetry."""
    from ..core.sensors import beam_directions

    dirs = beam_directions(rh_deg)[0]
    origins, rays = [], []
    for x, y, z, yaw in ANALYTIC_ORIGINS:
        rays.append(dirs @ _rotation(math.radians(yaw), math.radians(7.0), math.radians(3.0)).T)
        origins.append(np.broadcast_to([x, y, z], dirs.shape))
    return np.concatenate(origins), np.concatenate(rays)


def analytic_truth(
    solids: list[Solid], origins, dirs, max_range: float, tol: float = RANGE_TOLERANCE
) -> dict:
    """Exact first hits: distance (inf: none) and instance (-1) per ray, and `clear`: the
    same solid is hit first with every face moved out or in by `tol` (a ray grazing a
    silhouette may be seen or not by any correct caster: those rays are left out)."""

    def first(grow):
        t = np.stack([s.first_hit(origins, dirs, grow) for s in solids])
        k = np.argmin(t, axis=0)
        best = t[k, np.arange(len(dirs))]
        inst = np.where(
            np.isfinite(best) & (best <= max_range), np.array([s.instance for s in solids])[k], -1
        )
        return np.where(inst >= 0, best, np.inf), inst

    distance, instance = first(0.0)
    clear = (first(tol)[1] == instance) & (first(-tol)[1] == instance)
    clear &= ~(np.abs(np.where(np.isfinite(distance), distance, 0.0) - max_range) <= tol)
    return {"distance": distance, "instance": instance, "clear": clear}


def analytic_errors(hits, truth: dict, solids: list[Solid]) -> dict:
    """Range error (max, RMS) over the clear rays the backend labels right, the clear rays
    it labels wrong (or misses), and the max error per primitive."""
    from ..core.classes import class_id_for_tag

    class_of = {s.instance: class_id_for_tag(s.wildscan_class) for s in solids}
    want_class = np.array([class_of.get(int(i), -1) for i in truth["instance"]], dtype=np.int64)
    clear = truth["clear"]
    right = clear & (hits.instance == truth["instance"]) & (hits.class_id == want_class)
    on = right & np.isfinite(truth["distance"])
    err = np.abs(hits.distance[on] - truth["distance"][on])
    per = {
        s.name.replace("bench ", ""): float(err[truth["instance"][on] == s.instance].max(initial=0.0))
        for s in solids
    }
    return {
        "analytic_rays": int(on.sum()),
        "analytic_max_m": float(err.max(initial=0.0)),
        "analytic_rms_m": float(np.sqrt(np.mean(err**2))) if len(err) else 0.0,
        "analytic_wrong": int(np.count_nonzero(clear & ~right)),
        "analytic_excluded": int(np.count_nonzero(~clear)),
        "per_primitive": per,
    }


def bench_analytic(cfg: "BenchConfig", report: "Report") -> None:
    from ..blender.mesh import mesh_object, wildscan_collection
    from ..raycast.blender_backend import scene_depsgraph
    from ..raycast.extract import extract_scene

    solids = primitive_solids()
    origins, dirs = analytic_rays(cfg.analytic_rh)
    truth = analytic_truth(solids, origins, dirs, ANALYTIC_RANGE)
    rows = []
    with bench_scene("WildScanBench primitives") as scene:
        coll = wildscan_collection(BENCH_COLLECTION, parent=scene.collection)
        for s in solids:
            mesh_object(s.name, s.vertices, s.triangles(), coll, s.wildscan_class, s.instance)
        geometry = extract_scene(scene_depsgraph(scene))
        for name in cfg.all_backends:
            backend = reference_backend(scene) if name == REFERENCE else fast_backend(name, geometry)
            hits, cast_s = timed(backend.cast, origins, dirs, ANALYTIC_RANGE)
            row = {
                "section": "analytic",
                "world": "primitives",
                "backend": name,
                "objects": len(solids),
                "triangles": geometry.triangle_count,
                "rh_deg": cfg.analytic_rh,
                "beams": len(dirs),
                "ray_casting_s": cast_s,
                "us_per_ray": 1e6 * cast_s / len(dirs),
            }
            row.update(analytic_errors(hits, truth, solids))
            rows.append(row)
    report.add_rows(rows)
    report.analytic = rows
    report.say(format_analytic(rows, len(dirs), cfg.analytic_rh))


def format_analytic(rows: list[dict], rays: int, rh_deg: float) -> str:
    headers = [
        "backend",
        "hits compared",
        "max error m",
        "RMS m",
        "wrong",
        "excluded",
        "plane",
        "box",
        "sphere",
        "prism",
        "cast",
        "us/ray",
    ]
    body = [
        [
            backend_title(r["backend"]),
            f"{r['analytic_rays']:,}",
            metres(r["analytic_max_m"]),
            metres(r["analytic_rms_m"]),
            str(r["analytic_wrong"]),
            str(r["analytic_excluded"]),
            *(metres(r["per_primitive"][k]) for k in ("plane", "box", "sphere", "prism")),
            fmt_s(r["ray_casting_s"]),
            f"{r['us_per_ray']:.2f}",
        ]
        for r in rows
    ]
    return "\n".join(
        [
            f"\n== Analytic primitives: {rays:,} rays (the r_h = {rh_deg:g} deg pattern from "
            f"{len(ANALYTIC_ORIGINS)} origins) on a tilted plane, a box, a 16 x 32 UV-sphere polyhedron "
            "and a 48-sided prism; truth in closed form from the facet planes (float64)",
            text_table(headers, body),
            "range error |backend - truth| over hits labelled right; 'wrong' = rays with a clear truth "
            f"labelled wrong or missed; 'excluded' = rays within {RANGE_TOLERANCE:g} m of a silhouette "
            "(either answer is right)",
        ]
    )
