"""`wildscan bench`: speed and accuracy of every ray backend, side by side (bpy wheel).

One run measures, with range noise off so ranges can be compared:

  test world      one full r_h = 1 deg scan of the test world (world.testworld) per backend,
                  placement to PLY written, split into phases: placement, beam directions,
                  ray casting, labels + leveling, PLY write. Says what dominates.
  primitives      range error against analytic ground truth on a tilted plane, a box, a
                  UV-sphere polyhedron and a 48-sided prism: their intersections are computed
                  in closed form (float64, from their facet planes, never from triangles).
  default world   at each detail level, from a fixed set of poses (the first valid pose of
                  each zone): scan time (median of --runs), placement to PLY written; per-ray
                  label and range agreement with scene.ray_cast; terrain height error against
                  the analytic heightfield; ratios against scene.ray_cast. One FULL
                  scene.ray_cast scan of the default world is timed, so the headline ratio is
                  measured, not extrapolated.
  scaling         scan time against beams (r_h 4 -> 0.25 deg), triangles (detail levels) and
                  objects (synthetic scenes of N objects).
  targets         each goal of issue 5, met or not.

scene.ray_cast costs 30-700 us a ray here, so elsewhere it casts --reference-rays rays spread
evenly over each scan and its full-scan time is extrapolated (marked '~'). Every disagreement
with it is judged against the exact float64 brute force (raycast.geometry.check_hits) to say
whose answer is wrong. Timings run with the garbage collector paused, as timeit does.

Everything is built in scenes of its own, removed afterwards: the user's scenes are never
touched. Results: bench.csv, bench.png and scaling.md in --out (written together, all or none).

    wildscan bench [--quick] [--details low,default,high] [--backends embree,bvh] [--out DIR]
"""

from __future__ import annotations

import argparse
import csv
import gc
import io
import math
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .core.checks import whole_number
from .core.errors import PoseRejected, UserError
from .core.io.files import output_directory

RANGE_TOLERANCE = 1e-4  # metres: "ranges within 1e-4 m"
AGREEMENT_TARGET = 0.9999
SPEEDUP_TARGET = 100.0
FINE_RH = 0.25
FINE_SCAN_TARGET_S = 0.25
SCAN_RH = 1.0
ANALYTIC_TARGET_M = 1e-4
# "Flat in the number of objects", made measurable: over the object-count steps (30x the
# objects, and with them 12x the triangles and more hits in reach) the scan time may at most
# double; scene.ray_cast's time a ray grows ~40x there.
FLAT_TARGET = 2.0
BEAM_STEPS = (4.0, 2.0, 1.0, 0.5, 0.25)
QUICK_BEAM_STEPS = (4.0, 1.0, 0.25)
OBJECT_COUNTS = (100, 1000, 3000)
QUICK_OBJECT_COUNTS = (20, 200)
DEFAULT_RUNS, QUICK_RUNS = 3, 1
DEFAULT_REFERENCE_RAYS, QUICK_REFERENCE_RAYS = 2000, 300
TERRAIN_RAYS, QUICK_TERRAIN_RAYS = 20_000, 2_000
QUICK_ZONES = 2
DEFAULT_OUT = "out/bench"
BENCH_COLLECTION = "WildScanBench"
REFERENCE = "blender"
PHASES = ("placement", "beam_directions", "ray_casting", "labels_leveling", "ply_write")
PHASE_TITLES = {
    "placement": "placement",
    "beam_directions": "beam directions",
    "ray_casting": "ray casting",
    "labels_leveling": "labels + leveling",
    "ply_write": "PLY write",
}
DEFAULT_POSES = ((0.0, 0.0, 0.0), (8.0, -6.0, 30.0), (-12.0, 10.0, 90.0))  # synthetic scenes

CSV_COLUMNS = (
    "section",
    "world",
    "detail",
    "seed",
    "zone",
    "pose",
    "backend",
    "objects",
    "triangles",
    "crop_triangles",
    "rh_deg",
    "beams",
    "runs",
    "estimated",
    "scan_s",
    "placement_s",
    "beam_directions_s",
    "ray_casting_s",
    "labels_leveling_s",
    "ply_write_s",
    "us_per_ray",
    "build_world_s",
    "extract_s",
    "crop_s",
    "build_s",
    "speedup_vs_ray_cast",
    "rays_compared",
    "label_agreement",
    "range_agreement",
    "max_range_diff_m",
    "disagreements",
    "reference_wrong",
    "backend_wrong",
    "e2e_label_agreement",
    "e2e_range_agreement",
    "e2e_max_range_diff_m",
    "placement_diff_m",
    "terrain_max_m",
    "terrain_rms_m",
    "terrain_rays",
    "terrain_mesh_max_m",
    "analytic_max_m",
    "analytic_rms_m",
    "analytic_rays",
    "analytic_wrong",
    "analytic_excluded",
)


# =============================================================================================
# timing helpers


@contextmanager
def gc_paused():
    """Keep the garbage collector out of a timing (as timeit does)."""
    gc.collect()
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def timed(fn: Callable, *args, **kwargs):
    """(result, seconds) of one call, with the garbage collector kept out."""
    with gc_paused():
        start = time.perf_counter()
        result = fn(*args, **kwargs)
        return result, time.perf_counter() - start


def spread_subset(count: int, size: int | None) -> np.ndarray:
    """Indices of `size` rays spread evenly over `count` (all of them when size is None)."""
    if size is None or size >= count:
        return np.arange(count)
    return np.unique(np.linspace(0, count - 1, size).round().astype(np.int64))


# =============================================================================================
# agreement with the reference


def agreement(hits, reference) -> dict:
    """Per-ray agreement of two RayHits over the same rays (fractions)."""
    c = agreement_counts(hits, reference)
    n = max(c["rays"], 1)
    return {
        "label_agreement": c["labels_same"] / n if c["rays"] else 1.0,
        "range_agreement": c["ranges_ok"] / n if c["rays"] else 1.0,
        "max_range_diff_m": c["max_range_diff_m"],
    }


def agreement_counts(hits, reference) -> dict:
    """Counts over the same rays: same label (class and instance; two misses agree), and
    same label with ranges within RANGE_TOLERANCE; `disagree` indexes the rays that fail."""
    same = (hits.class_id == reference.class_id) & (hits.instance == reference.instance)
    both = same & hits.hit & reference.hit
    diff = np.abs(hits.distance[both] - reference.distance[both])
    within = same.copy()
    within[both] = diff <= RANGE_TOLERANCE
    return {
        "rays": len(same),
        "labels_same": int(same.sum()),
        "ranges_ok": int(within.sum()),
        "max_range_diff_m": float(diff.max()) if len(diff) else 0.0,
        "disagree": np.flatnonzero(~within),
    }


def _take(hits, index: np.ndarray):
    from .raycast.base import RayHits

    return RayHits(hits.distance[index], hits.class_id[index], hits.instance[index], hits.untagged_objects)


def wrong_answers(geometry, origin, directions, max_range: float, hits, index: np.ndarray) -> int:
    """How many of the rays `index` a backend answered wrongly, by exact float64 brute force."""
    from .raycast.geometry import check_hits

    if not len(index):
        return 0
    ok = check_hits(
        geometry, origin, directions[index], max_range, _take(hits, index), range_tol=RANGE_TOLERANCE
    )
    return int(np.count_nonzero(~ok))


@dataclass
class Agreement:
    """Running totals of a backend's agreement with the reference, over several comparisons."""

    rays: int = 0
    labels_same: int = 0
    ranges_ok: int = 0
    max_range_diff_m: float = 0.0
    disagreements: int = 0
    reference_wrong: int = 0
    backend_wrong: int = 0

    def add(self, counts: dict, reference_wrong: int, backend_wrong: int) -> "Agreement":
        self.rays += counts["rays"]
        self.labels_same += counts["labels_same"]
        self.ranges_ok += counts["ranges_ok"]
        self.max_range_diff_m = max(self.max_range_diff_m, counts["max_range_diff_m"])
        self.disagreements += len(counts["disagree"])
        self.reference_wrong += reference_wrong
        self.backend_wrong += backend_wrong
        return self

    def row(self) -> dict:
        if not self.rays:
            return {}
        return {
            "rays_compared": self.rays,
            "label_agreement": self.labels_same / self.rays,
            "range_agreement": self.ranges_ok / self.rays,
            "max_range_diff_m": self.max_range_diff_m,
            "disagreements": self.disagreements,
            "reference_wrong": self.reference_wrong,
            "backend_wrong": self.backend_wrong,
        }


# =============================================================================================
# one scan, placement to PLY written, split into phases


class _CastLog:
    """A backend wrapper that notes when each cast ran, to split run_scan into phases: its
    casts before the sweep are the placement lasers, the last one is the sweep."""

    def __init__(self, backend):
        self.backend = backend
        self.name = backend.name
        self.calls: list[tuple[float, float, int, object]] = []

    def cast(self, origins, directions, max_range):
        start = time.perf_counter()
        hits = self.backend.cast(origins, directions, max_range)
        self.calls.append((start, time.perf_counter(), len(directions), hits))
        return hits


@dataclass
class ScanRun:
    """Median phase times of a scan and what its (last) run returned."""

    backend: str
    phases: dict[str, float]
    total: float
    hits: object  # RayHits of the sweep
    result: object  # core.scan.ScanResult
    rh_deg: float
    runs: int = 1

    @property
    def origin(self) -> np.ndarray:
        return self.result.placement.optical_centre

    def directions(self) -> np.ndarray:
        from .core.sensor import beam_directions

        return beam_directions(self.rh_deg)[0] @ self.result.placement.rotation.T

    @property
    def beams(self) -> int:
        return int(self.result.beams)

    def row(self) -> dict:
        row = {f"{k}_s": v for k, v in self.phases.items()}
        row.update(
            scan_s=self.total,
            runs=self.runs,
            rh_deg=self.rh_deg,
            beams=self.beams,
            us_per_ray=1e6 * self.phases["ray_casting"] / max(self.beams, 1),
        )
        return row


def noise_free(rh_deg: float):
    from .core.sensor import SensorConfig

    return SensorConfig(rh_deg=rh_deg, noise_sigma=0.0).validate()


def timed_scan(backend, pose, z_start, rh_deg: float, ply_path: Path) -> ScanRun:
    """One full scan with run_scan (placement, sweep, labels, leveling) and its PLY + JSON
    written with write_scan_files, the way `wildscan scan` does it, timed by phase."""
    from .core.io.ply import write_scan_files
    from .core.scan import run_scan

    log = _CastLog(backend)
    sensor = noise_free(rh_deg)
    with gc_paused():
        t0 = time.perf_counter()
        result = run_scan(log, pose, sensor, z_start=z_start)
        t1 = time.perf_counter()
        write_scan_files(ply_path, result.cloud, result.metadata)
        t2 = time.perf_counter()
    *lasers, sweep = log.calls
    if sweep[2] != result.beams:
        raise RuntimeError(
            f"expected the sweep ({result.beams} rays) to be the last cast, got {sweep[2]} rays"
        )
    placed = lasers[-1][1] if lasers else t0
    phases = {
        "placement": placed - t0,
        "beam_directions": sweep[0] - placed,
        "ray_casting": sweep[1] - sweep[0],
        "labels_leveling": t1 - sweep[1],
        "ply_write": t2 - t1,
    }
    return ScanRun(backend.name, phases, t2 - t0, sweep[3], result, rh_deg)


def median_scan(backend, pose, z_start, rh_deg: float, ply_path: Path, runs: int) -> ScanRun:
    """Per-phase and total medians over `runs` scans."""
    done = [timed_scan(backend, pose, z_start, rh_deg, ply_path) for _ in range(max(1, runs))]
    phases = {k: statistics.median(r.phases[k] for r in done) for k in PHASES}
    last = done[-1]
    return ScanRun(
        last.backend,
        phases,
        statistics.median(r.total for r in done),
        last.hits,
        last.result,
        rh_deg,
        len(done),
    )


# =============================================================================================
# scenes of the bench's own


@contextmanager
def bench_scene(name: str):
    """A new scene for the bench, removed afterwards with everything the bench made in it."""
    import bpy

    scene = bpy.data.scenes.new(name)
    try:
        yield scene
    finally:
        _remove_bench_scene(scene)


def _remove_bench_scene(scene) -> None:
    import bpy

    from .world.mesh import remove_generated

    remove_generated(BENCH_COLLECTION)
    bpy.data.scenes.remove(scene)


@contextmanager
def scene_context(scene):
    """Make `scene` the context scene for builders that use bpy.context.scene."""
    import bpy

    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
        yield


def reference_backend(scene):
    from .raycast.blender_backend import BlenderRayCastBackend, scene_depsgraph

    return BlenderRayCastBackend(scene=scene, depsgraph=scene_depsgraph(scene))


def fast_backend(name: str, geometry):
    """A ready fast backend: Embree builds its BVH lazily on the first cast, so one ray is
    cast here and that build is counted with the backend's build time, not the first scan's."""
    from .raycast.select import make_backend

    backend = make_backend(name, geometry=geometry, notify=None)
    backend.cast(geometry.offset, np.array([[0.0, 0.0, -1.0]]), 1.0)
    return backend


def crop_for(whole, pose, rh_deg: float = SCAN_RH):
    """What `wildscan scan` keeps of the world for this pose (scanning.make_scene_backend)."""
    from .scanning import crop_radius

    return whole.cropped((pose.x, pose.y), crop_radius(noise_free(rh_deg)))


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
    from .core.sensor import beam_directions

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
    from .core.classes import class_id_for_tag

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
    from .raycast.blender_backend import scene_depsgraph
    from .raycast.extract import extract_scene
    from .world.mesh import mesh_object, wildscan_collection

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


# =============================================================================================
# the test world: one full scan per backend, by phase


def bench_test_world(cfg: "BenchConfig", report: "Report", tmp: Path) -> None:
    from .core.placement import Pose
    from .raycast.blender_backend import scene_depsgraph
    from .raycast.extract import extract_scene
    from .world.testworld import build_test_world

    pose = Pose(0.0, 0.0, 0.0)
    with bench_scene("WildScanBench test world") as scene:
        with scene_context(scene):
            build_test_world(cfg.seed, collection_name=BENCH_COLLECTION)
        objects = len([o for o in scene.objects if o.type == "MESH"])
        whole, extract_s = timed(extract_scene, scene_depsgraph(scene))
        report.say(
            f"\n== Test world (world.testworld, seed {cfg.seed}: {objects} objects, {whole.triangle_count:,} "
            f"triangles), pose (0, 0, 0): one full r_h = {SCAN_RH:g} deg scan with scene.ray_cast ..."
        )
        runs = measure_phases(cfg, whole, scene, pose, None, tmp)
    rows = phase_rows(
        runs,
        world="test world",
        objects=objects,
        triangles=whole.triangle_count,
        extract_s=extract_s,
        seed=cfg.seed,
        pose=pose,
    )
    report.add_rows(rows)
    report.test_world = rows
    report.say(format_phases(rows, f"test world, seed {cfg.seed}", extract_s))


def measure_phases(cfg, whole, scene, pose, z_start, tmp: Path, full_reference: bool = True) -> dict:
    """Full r_h = 1 deg scans from `pose` with scene.ray_cast (once, when asked) and each fast
    backend (median of runs); with each one's build time and agreement with the reference."""
    geometry, crop_s = timed(crop_for, whole, pose)
    runs: dict[str, tuple] = {}
    backends = {}
    if full_reference:
        runs[REFERENCE] = (
            median_scan(reference_backend(scene), pose, z_start, SCAN_RH, tmp / "ref.ply", 1),
            0.0,
        )
    for name in cfg.fast_backends:
        backend, build_s = timed(fast_backend, name, geometry)
        backends[name] = backend
        run = median_scan(backend, pose, z_start, SCAN_RH, tmp / f"{name}.ply", cfg.runs)
        runs[name] = (run, build_s)
        if full_reference:
            runs[name] += compare_runs(geometry, backend, run, runs[REFERENCE][0])
    return {"runs": runs, "geometry": geometry, "crop_s": crop_s, "backends": backends}


def compare_runs(geometry, backend, run: ScanRun, ref: ScanRun) -> tuple[Agreement, dict]:
    """A full scan against the full reference scan, beam by beam, two ways:
    same rays   the backend re-casts the reference's own rays (its placement): the backends
                compared as ray casters; disagreements judged by exact float64 brute force;
    end to end  each scan with its own placement, as the two PLY files would differ. The
                placements differ by float32 round-off (scene.ray_cast's lasers), which
                moves a grazing beam's range by far more than the 1e-4 m tolerance."""
    max_range = noise_free(run.rh_deg).max_range
    dirs = ref.directions()
    again = backend.cast(ref.origin, dirs, max_range)
    counts = agreement_counts(again, ref.hits)
    idx = counts["disagree"]
    same = Agreement().add(
        counts,
        wrong_answers(geometry, ref.origin, dirs, max_range, ref.hits, idx),
        wrong_answers(geometry, ref.origin, dirs, max_range, again, idx),
    )
    e2e = agreement_counts(run.hits, ref.hits)
    n = max(e2e["rays"], 1)
    return same, {
        "e2e_label_agreement": e2e["labels_same"] / n,
        "e2e_range_agreement": e2e["ranges_ok"] / n,
        "e2e_max_range_diff_m": e2e["max_range_diff_m"],
        "placement_diff_m": float(np.linalg.norm(run.origin - ref.origin)),
    }


def phase_rows(
    measured: dict,
    world: str,
    objects: int,
    triangles: int,
    extract_s: float,
    seed: int,
    pose,
    detail: str = "",
    zone: str = "",
) -> list[dict]:
    runs = measured["runs"]
    ref_total = runs[REFERENCE][0].total if REFERENCE in runs else math.nan
    rows = []
    for name, entry in runs.items():
        run, build_s = entry[0], entry[1]
        row = {
            "section": "phases",
            "world": world,
            "detail": detail,
            "seed": seed,
            "zone": zone,
            "pose": pose_text(pose),
            "backend": name,
            "objects": objects,
            "triangles": triangles,
            "crop_triangles": measured["geometry"].triangle_count,
            "estimated": False,
            "extract_s": 0.0 if name == REFERENCE else extract_s,
            "build_s": build_s,
            "crop_s": 0.0 if name == REFERENCE else measured["crop_s"],
            "speedup_vs_ray_cast": ref_total / run.total,
        }
        row.update(run.row())
        if len(entry) > 2:
            row.update(entry[2].row(), **entry[3])
        rows.append(row)
    return rows


def pose_text(pose) -> str:
    return f"{pose.x:g} {pose.y:g} {pose.yaw_deg:g}"


# =============================================================================================
# the default world at each detail level


def fixed_poses(seed: int, zones: int | None = None) -> list[tuple[str, object, float | None]]:
    """(zone, Pose, z_start): the first valid pose of each zone of the default-detail world.
    The same poses are used at every detail level (the layout does not change with it)."""
    from .core.placement import Pose
    from .core.worldplan import ZONES, plan_world
    from .world_cli import plan_backend, valid_poses

    plan = plan_world(seed, "default")
    chosen = ZONES[:zones] if zones else ZONES
    found = valid_poses(plan, plan_backend(plan), 1, chosen)
    return [
        (zone, Pose(p["x"], p["y"], p["yaw"]), p.get("z_start")) for zone in chosen for p in found[zone][:1]
    ]


def bench_world_levels(cfg: "BenchConfig", report: "Report", tmp: Path) -> None:
    poses = fixed_poses(cfg.seed, QUICK_ZONES if cfg.quick else None)
    if not poses:
        raise UserError(f"--seed {cfg.seed}: the world has no valid scan pose to benchmark")
    report.poses = poses
    report.say(
        f"\n== Default world, seed {cfg.seed}: {len(poses)} poses (first valid pose per zone): "
        + "; ".join(f"{z} ({pose_text(p)}{'' if zs is None else f', z-start {zs:g}'})" for z, p, zs in poses)
    )
    for detail in cfg.details:
        bench_level(cfg, report, detail, poses, tmp)
    report.say(format_levels(report.level_rows, cfg))


def bench_level(cfg, report: "Report", detail: str, poses, tmp: Path) -> None:
    from .raycast.blender_backend import scene_depsgraph
    from .raycast.extract import extract_scene
    from .world.builder import build_world

    with bench_scene(f"WildScanBench {detail}") as scene:
        with scene_context(scene):
            plan, build_world_s = timed(build_world, cfg.seed, detail, collection_name=BENCH_COLLECTION)
        whole, extract_s = timed(extract_scene, scene_depsgraph(scene))
        objects = plan.counts()["objects"]
        report.say(
            f"-- {detail}: {objects:,} objects, {whole.triangle_count:,} triangles; world built in "
            f"{build_world_s:.2f} s, extracted in {extract_s:.3f} s"
        )
        base = {
            "world": "default world",
            "detail": detail,
            "seed": cfg.seed,
            "objects": objects,
            "triangles": whole.triangle_count,
            "build_world_s": build_world_s,
            "extract_s": extract_s,
        }
        reference = reference_backend(scene)
        per_pose: list[dict] = []
        for zone, pose, z_start in poses:
            # the headline (a full scene.ray_cast scan) and the beam scaling: from the first pose
            # the placement accepts at the headline detail
            first = detail == cfg.headline_detail and not report.beam_rows
            try:
                rows = bench_pose(
                    cfg,
                    report,
                    base,
                    whole,
                    scene,
                    reference,
                    zone,
                    pose,
                    z_start,
                    first and cfg.full_reference,
                    tmp,
                )
            except PoseRejected as e:
                report.say(f"   {zone}: skipped at {detail} detail ({e})")
                continue
            per_pose += rows
            if first:
                bench_beams(cfg, report, base, whole, reference, pose, z_start, rows, tmp)
        terrain = bench_terrain(cfg, plan, whole, reference)
    report.add_rows(per_pose)
    summary = level_summary(cfg, base, per_pose, terrain, plan)
    report.add_rows(summary)
    report.level_rows += summary


def bench_pose(
    cfg, report, base, whole, scene, reference, zone, pose, z_start, full: bool, tmp: Path
) -> list[dict]:
    """Every backend from one pose: fast ones in full (median of runs); scene.ray_cast in
    full when `full`, else on --reference-rays rays of the first fast backend's scan."""
    if full:
        report.say(
            f"   {zone}: full r_h = {SCAN_RH:g} deg scan with scene.ray_cast, the measured reference (slow: "
            f"one Python call a ray, each costing more the more objects the scene has) ..."
        )
    measured = measure_phases(cfg, whole, scene, pose, z_start, tmp, full_reference=full)
    runs, geometry = measured["runs"], measured["geometry"]
    first = runs[cfg.fast_backends[0]][0]
    if full:
        ref_run = runs[REFERENCE][0]
        ref = {"scan_s": ref_run.total, "estimated": False, **ref_run.row()}
    else:
        ref = subset_reference(cfg, reference, first, geometry, runs, measured["backends"])
    rows = []
    for name in cfg.all_backends:
        row = dict(
            base,
            section="pose",
            zone=zone,
            pose=pose_text(pose),
            backend=name,
            crop_triangles=geometry.triangle_count,
        )
        if name == REFERENCE:
            row.update(ref)
            row.update(extract_s=0.0, crop_s=0.0, build_s=0.0)
        else:
            run, build_s, agree, extra = runs[name]
            row.update(
                run.row(),
                estimated=False,
                build_s=build_s,
                crop_s=measured["crop_s"],
                agreement=agree,
                **extra,
            )
            row.update(agree.row())
        row["speedup_vs_ray_cast"] = ref["scan_s"] / row["scan_s"]
        rows.append(row)
    if full:
        report.headline = {
            "pose": pose,
            "zone": zone,
            "detail": base["detail"],
            "objects": base["objects"],
            "runs": runs,
            "extract_s": base["extract_s"],
            "triangles": base["triangles"],
        }
        report.say(
            format_phases(
                phase_rows(
                    measured,
                    "default world",
                    base["objects"],
                    base["triangles"],
                    base["extract_s"],
                    cfg.seed,
                    pose,
                    base["detail"],
                    zone,
                ),
                f"default world, {base['detail']} detail, {zone} pose",
                base["extract_s"],
            )
        )
    return rows


def subset_reference(cfg, reference, first: ScanRun, geometry, runs: dict, backends: dict) -> dict:
    """scene.ray_cast on an evenly spread subset of `first`'s rays (same origin): its per-ray
    time, its full scan extrapolated (~, with the other phases as `first` measured them),
    and every fast backend's agreement with it on those very rays (each re-casts them)."""
    dirs = first.directions()
    subset = spread_subset(len(dirs), cfg.reference_rays)
    max_range = noise_free(SCAN_RH).max_range
    rays = np.ascontiguousarray(dirs[subset])
    hits, seconds = timed(reference.cast, first.origin, rays, max_range)
    per_ray = seconds / len(subset)
    other = {k: v for k, v in first.phases.items() if k != "ray_casting"}
    estimate = dict({f"{k}_s": v for k, v in other.items()}, ray_casting_s=per_ray * len(dirs))
    ref = dict(
        estimate,
        scan_s=sum(other.values()) + per_ray * len(dirs),
        us_per_ray=1e6 * per_ray,
        estimated=True,
        runs=1,
        rh_deg=SCAN_RH,
        beams=len(dirs),
    )
    for name in cfg.fast_backends:
        run, build_s = runs[name][:2]
        mine = backends[name].cast(first.origin, rays, max_range)
        counts = agreement_counts(mine, hits)
        idx = counts["disagree"]
        ref_wrong = wrong_answers(geometry, first.origin, rays, max_range, hits, idx)
        own_wrong = wrong_answers(geometry, first.origin, rays, max_range, mine, idx)
        runs[name] = (run, build_s, Agreement().add(counts, ref_wrong, own_wrong), {})
    return ref


def bench_terrain(cfg, plan, whole, reference) -> dict:
    """Terrain height error of each backend's hits against the analytic heightfield: rays
    straight down at random points; only hits on the terrain mesh itself are compared (not
    water, plants, the trail or the cave roof above it)."""
    from .core.classes import class_by_name
    from .core.rng import stage_rng
    from .core.worldplan import EXTENT

    terrain = plan.elements_of("terrain", stage="terrain")[0].instance
    x0, x1, y0, y1 = EXTENT
    xy = stage_rng(cfg.seed, "bench.terrain").uniform(
        [x0 + 1, y0 + 1], [x1 - 1, y1 - 1], size=(cfg.terrain_rays, 2)
    )
    top = float(whole.vertices[:, 2].max()) + 1.0
    reach = top - float(whole.vertices[:, 2].min()) + 1.0
    origins = np.column_stack([xy, np.full(len(xy), top)])
    down = np.broadcast_to([0.0, 0.0, -1.0], origins.shape)
    truth = plan.heightfield(xy[:, 0], xy[:, 1])
    mesh = plan.grid.height_at(xy[:, 0], xy[:, 1])  # the triangulated grid: what a ray should hit
    terrain_id = class_by_name("terrain").id
    out = {}
    for name in cfg.all_backends:
        count = min(cfg.reference_rays, len(xy)) if name == REFERENCE else len(xy)
        backend = reference if name == REFERENCE else fast_backend(name, whole)
        hits = backend.cast(origins[:count], np.ascontiguousarray(down[:count]), reach)
        on = (hits.instance == terrain) & (hits.class_id == terrain_id)
        z = top - hits.distance[on]
        err = np.abs(z - truth[:count][on])
        out[name] = {
            "terrain_max_m": float(err.max(initial=0.0)),
            "terrain_rms_m": float(np.sqrt(np.mean(err**2))) if len(err) else math.nan,
            "terrain_rays": int(on.sum()),
            "terrain_mesh_max_m": float(np.abs(z - mesh[:count][on]).max(initial=0.0)),
        }
    return out


def level_summary(cfg, base: dict, per_pose: list[dict], terrain: dict, plan) -> list[dict]:
    """One row per backend: medians over poses, agreement summed over every compared ray."""
    rows = []
    ref_scan = _median(r["scan_s"] for r in per_pose if r["backend"] == REFERENCE)
    for name in cfg.all_backends:
        mine = [r for r in per_pose if r["backend"] == name]
        if not mine:
            continue
        row = dict(
            base,
            section="detail",
            backend=name,
            zone="all",
            pose=f"{len(mine)} poses",
            rh_deg=SCAN_RH,
            beams=mine[0]["beams"],
            runs=mine[0]["runs"],
            estimated=any(r["estimated"] for r in mine),
        )
        for key in (
            "scan_s",
            *(f"{p}_s" for p in PHASES),
            "us_per_ray",
            "crop_triangles",
            "crop_s",
            "build_s",
        ):
            row[key] = _median(r.get(key, math.nan) for r in mine)
        row["speedup_vs_ray_cast"] = ref_scan / row["scan_s"]
        if name != REFERENCE:
            row.update(sum_agreements(r["agreement"] for r in mine).row())
        row.update(terrain.get(name, {}))
        rows.append(row)
    for row in rows:
        row["terrain_fit_max_m"] = plan.grid_fit.error.max
        row["terrain_fit_rms_m"] = plan.grid_fit.error.rms
    return rows


def sum_agreements(parts) -> Agreement:
    total = Agreement()
    for a in parts:
        total.rays += a.rays
        total.labels_same += a.labels_same
        total.ranges_ok += a.ranges_ok
        total.max_range_diff_m = max(total.max_range_diff_m, a.max_range_diff_m)
        total.disagreements += a.disagreements
        total.reference_wrong += a.reference_wrong
        total.backend_wrong += a.backend_wrong
    return total


def _median(values) -> float:
    values = [v for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]
    return statistics.median(values) if values else math.nan


# =============================================================================================
# scaling: beams and objects


def bench_beams(cfg, report, base, whole, reference, pose, z_start, per_pose, tmp: Path) -> None:
    """Scan time against r_h from one pose: fast backends measured, scene.ray_cast
    extrapolated from its per-ray time at this pose (it grows as the beams do)."""
    geometry, crop_s = timed(crop_for, whole, pose)
    ref_row = next(r for r in per_pose if r["backend"] == REFERENCE)
    rows = []
    for name in cfg.fast_backends:
        backend, build_s = timed(fast_backend, name, geometry)
        for rh in cfg.beam_steps:
            run = median_scan(backend, pose, z_start, rh, tmp / f"{name}-rh.ply", cfg.runs)
            row = dict(
                base,
                section="beams",
                zone=ref_row["zone"],
                pose=pose_text(pose),
                backend=name,
                crop_triangles=geometry.triangle_count,
                crop_s=crop_s,
                build_s=build_s,
                estimated=False,
            )
            row.update(run.row())
            rows.append(row)
    for rh in cfg.beam_steps:
        beams = next(r["beams"] for r in rows if r["rh_deg"] == rh)
        fast = next(r for r in rows if r["rh_deg"] == rh)
        other = fast["scan_s"] - fast["ray_casting_s"]
        cast = ref_row["us_per_ray"] * 1e-6 * beams
        rows.append(
            dict(
                base,
                section="beams",
                zone=ref_row["zone"],
                pose=pose_text(pose),
                backend=REFERENCE,
                rh_deg=rh,
                beams=beams,
                estimated=True,
                ray_casting_s=cast,
                scan_s=cast + other,
                us_per_ray=ref_row["us_per_ray"],
                runs=1,
            )
        )
    for row in rows:
        ref = next(r for r in rows if r["backend"] == REFERENCE and r["rh_deg"] == row["rh_deg"])
        row["speedup_vs_ray_cast"] = ref["scan_s"] / row["scan_s"]
    report.add_rows(rows)
    report.beam_rows = rows


def bench_objects(cfg: "BenchConfig", report: "Report", tmp: Path) -> None:
    """Scan time against the number of objects: terrain plus N rocks and trees, each its own
    mesh object (build_many_objects_scene), one pose, full r_h = 1 deg scans."""
    from .core.placement import Pose
    from .raycast.blender_backend import scene_depsgraph
    from .raycast.extract import extract_scene

    pose = Pose(*DEFAULT_POSES[0])
    rows = []
    for count in cfg.object_counts:
        with bench_scene(f"WildScanBench {count} objects") as scene:
            build_many_objects_scene(count, seed=cfg.seed, scene=scene)
            objects = len([o for o in scene.objects if o.type == "MESH"])
            whole, extract_s = timed(extract_scene, scene_depsgraph(scene))
            geometry, crop_s = timed(crop_for, whole, pose)
            base = {
                "section": "objects",
                "world": f"{count} rocks/trees",
                "seed": cfg.seed,
                "pose": pose_text(pose),
                "objects": objects,
                "triangles": whole.triangle_count,
                "crop_triangles": geometry.triangle_count,
                "extract_s": extract_s,
                "crop_s": crop_s,
            }
            runs, backends = {}, {}
            for name in cfg.fast_backends:
                backends[name], build_s = timed(fast_backend, name, geometry)
                runs[name] = (
                    median_scan(backends[name], pose, None, SCAN_RH, tmp / f"{name}-obj.ply", cfg.runs),
                    build_s,
                )
            ref = subset_reference(
                cfg, reference_backend(scene), runs[cfg.fast_backends[0]][0], geometry, runs, backends
            )
        rows.append(dict(base, backend=REFERENCE, **ref, speedup_vs_ray_cast=1.0))
        for name in cfg.fast_backends:
            run, build_s, agree, _ = runs[name]
            row = dict(base, backend=name, build_s=build_s, estimated=False, **run.row())
            row.update(agree.row(), speedup_vs_ray_cast=ref["scan_s"] / run.total)
            rows.append(row)
    report.add_rows(rows)
    report.object_rows = rows


# =============================================================================================
# formatting


def text_table(
    headers: Sequence[str], rows: Sequence[Sequence[str]], right: Sequence[bool] | None = None
) -> str:
    """A plain aligned table."""
    right = right or [i > 0 for i in range(len(headers))]
    widths = [
        max(len(str(h)), *(len(str(r[i])) for r in rows)) if rows else len(str(h))
        for i, h in enumerate(headers)
    ]

    def line(cells):
        return "  ".join(
            str(c).rjust(w) if r else str(c).ljust(w) for c, w, r in zip(cells, widths, right)
        ).rstrip()

    return "\n".join([line(headers), line(["-" * w for w in widths])] + [line(r) for r in rows])


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    out = [
        "| " + " | ".join(headers) + " |",
        "|" + "|".join("---:" if i else "---" for i in range(len(headers))) + "|",
    ]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def fmt_s(value, estimated: bool = False) -> str:
    """Seconds with their unit, '~' in front when extrapolated."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    mark = "~" if estimated else ""
    if value >= 100:
        return f"{mark}{value:.0f} s"
    if value >= 1:
        return f"{mark}{value:.2f} s"
    return f"{mark}{value:.3f} s" if value >= 0.01 else f"{mark}{value * 1e3:.2f} ms"


def ratio(value, estimated: bool = False) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    mark = "~" if estimated else ""
    return f"{mark}{value:,.0f}x" if value >= 10 else f"{mark}{value:.2f}x"


def percent(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100 * value:.4f}%"


def metres(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.1e}"


def backend_title(name: str) -> str:
    return "blender (scene.ray_cast)" if name == REFERENCE else name


def format_phases(rows: list[dict], title: str, extract_s: float) -> str:
    names = [r["backend"] for r in rows]
    headers = ["phase"] + [backend_title(n) for n in names]
    body = []
    for p in PHASES:
        body.append(
            [PHASE_TITLES[p]]
            + [f"{fmt_s(r[f'{p}_s'])} ({100 * r[f'{p}_s'] / r['scan_s']:.0f}%)" for r in rows]
        )
    body.append(["total: placement to PLY"] + [fmt_s(r["scan_s"]) for r in rows])
    body.append(["x vs scene.ray_cast"] + [ratio(r["speedup_vs_ray_cast"]) for r in rows])
    body.append(["runs (median)"] + [str(r["runs"]) for r in rows])
    body.append(
        ["scene prep (apart)"]
        + [
            "none" if r["backend"] == REFERENCE else f"{fmt_s(r['crop_s'] + r['build_s'])} crop+build"
            for r in rows
        ]
    )

    def fast(fn):
        return ["reference" if r["backend"] == REFERENCE else fn(r) for r in rows]

    body.append(["same rays: labels identical"] + fast(lambda r: percent(r.get("label_agreement"))))
    body.append(["same rays: ranges within 1e-4 m"] + fast(lambda r: percent(r.get("range_agreement"))))
    body.append(["same rays: max |dr|"] + fast(lambda r: f"{metres(r.get('max_range_diff_m'))} m"))
    body.append(
        ["  wrong by brute force (ref/own)"]
        + fast(lambda r: f"{r['reference_wrong']}/{r['backend_wrong']} of {r['disagreements']}")
    )
    body.append(["own placement: labels identical"] + fast(lambda r: percent(r.get("e2e_label_agreement"))))
    body.append(["own placement: ranges within 1e-4"] + fast(lambda r: percent(r.get("e2e_range_agreement"))))
    body.append(["optical centre vs ray_cast's"] + fast(lambda r: f"{metres(r.get('placement_diff_m'))} m"))
    lines = [
        f"\nfull r_h = {SCAN_RH:g} deg scan ({rows[0]['beams']:,} beams, noise off), {title}, by phase "
        "(same rays = the backend re-casts scene.ray_cast's beams; own placement = the two scans as written, "
        "each placed by its own lasers):",
        text_table(headers, body),
    ]
    ref = next((r for r in rows if r["backend"] == REFERENCE), None)
    if ref is not None:
        top = max(PHASES, key=lambda p: ref[f"{p}_s"])
        lines.append(
            f"scene.ray_cast scan: {fmt_s(ref['scan_s'])}, dominated by {PHASE_TITLES[top]} "
            f"({100 * ref[f'{top}_s'] / ref['scan_s']:.1f}%, {ref['us_per_ray']:.1f} us a ray over "
            f"{ref['objects']:,} objects); whole-scene extraction for the fast backends "
            f"{fmt_s(extract_s)}, reported apart"
        )
    return "\n".join(lines)


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
            f"\n== Analytic primitives: {rays:,} rays (the r_h = {rh_deg:g} deg pattern from {len(ANALYTIC_ORIGINS)} "
            "origins) on a tilted plane, a box, a 16 x 32 UV-sphere polyhedron and a 48-sided prism; truth in "
            "closed form from the facet planes (float64)",
            text_table(headers, body),
            "range error |backend - truth| over hits labelled right; 'wrong' = rays with a clear truth labelled wrong "
            f"or missed; 'excluded' = rays within {RANGE_TOLERANCE:g} m of a silhouette (either answer is right)",
        ]
    )


def format_levels(rows: list[dict], cfg) -> str:
    headers = [
        "detail",
        "objects",
        "triangles",
        "crop tris",
        "backend",
        "scan",
        "cast",
        "us/ray",
        "x ray_cast",
        "rays cmp",
        "labels same",
        "ranges ok",
        "max |dr| m",
        "ref/own wrong",
        "terrain max m",
        "terrain RMS m",
    ]
    body = []
    for r in rows:
        ref = r["backend"] == REFERENCE
        est = bool(r["estimated"])
        body.append(
            [
                r["detail"],
                f"{r['objects']:,}",
                f"{r['triangles']:,}",
                f"{r['crop_triangles']:,.0f}",
                backend_title(r["backend"]),
                fmt_s(r["scan_s"], est),
                fmt_s(r["ray_casting_s"], est),
                f"{r['us_per_ray']:.2f}",
                "1 (ref)" if ref else ratio(r["speedup_vs_ray_cast"], _est_ref(rows, r)),
                "-" if ref else f"{r['rays_compared']:,}",
                "-" if ref else percent(r["label_agreement"]),
                "-" if ref else percent(r["range_agreement"]),
                "-" if ref else metres(r["max_range_diff_m"]),
                "-" if ref else f"{r['reference_wrong']}/{r['backend_wrong']} of {r['disagreements']}",
                f"{r['terrain_max_m']:.4f}",
                f"{r['terrain_rms_m']:.4f}",
            ]
        )
    fits = {r["detail"]: (r["terrain_fit_max_m"], r["terrain_fit_rms_m"]) for r in rows}
    return "\n".join(
        [
            f"\nfull r_h = {SCAN_RH:g} deg scans, placement to PLY written, medians over the poses (each the median of "
            f"{cfg.runs} runs); '~' = scene.ray_cast extrapolated from {cfg.reference_rays:,} rays a pose, other phases "
            "as the first fast backend measured them; 'rays cmp' = rays compared with scene.ray_cast (subsets, and every "
            "beam of the one full reference scan); ref/own wrong = of the disagreeing rays, where scene.ray_cast / this "
            "backend is wrong by exact float64 brute force",
            text_table(headers, body, [False, True, True, True, False] + [True] * 11),
            "terrain error = |hit height - analytic heightfield| straight down at "
            f"{cfg.terrain_rays:,} random points ({min(cfg.reference_rays, cfg.terrain_rays):,} for scene.ray_cast); "
            "the mesh alone (fit_grid, 100k points): "
            + ", ".join(f"{d} max {m:.4f} / RMS {s:.4f} m" for d, (m, s) in fits.items()),
            "hit height vs the triangulated terrain mesh itself (the backends' own error): max "
            + ", ".join(
                f"{backend_title(r['backend'])} {r['detail']} {r['terrain_mesh_max_m']:.1e} m" for r in rows
            ),
        ]
        + terrain_tolerance_notes(rows)
    )


def terrain_tolerance_notes(rows: list[dict]) -> list[str]:
    """Say so where the measured terrain error exceeds the level's tolerance."""
    from .core.worldplan import DETAILS

    notes = []
    for detail in dict.fromkeys(r["detail"] for r in rows):
        worst = max(r["terrain_max_m"] for r in rows if r["detail"] == detail)
        tol = DETAILS[detail].terrain_tolerance
        if worst > tol:
            notes.append(
                f"note: at {detail} detail the terrain mesh is {worst:.4f} m off the analytic field somewhere "
                f"(tolerance {tol:g} m): fit_grid checks its tolerance on a sample of points, and the rays "
                "found a place it missed (the backends agree with the mesh itself, see above)"
            )
    return notes


def _est_ref(rows, r) -> bool:
    return any(x["estimated"] for x in rows if x["backend"] == REFERENCE and x["detail"] == r["detail"])


def scaling_tables(report: "Report", cfg) -> list[tuple[str, list[str], list[list[str]]]]:
    """(title, headers, rows) of the beams, triangles and objects scaling tables."""
    tables = []
    fast = cfg.fast_backends
    if report.beam_rows:
        headers = (
            ["r_h (deg)", "beams"]
            + [f"{n} scan" for n in fast]
            + [f"{n} cast" for n in fast]
            + ["scene.ray_cast scan", f"{fast[0]} x ray_cast"]
        )
        body = []
        for rh in cfg.beam_steps:
            at = {r["backend"]: r for r in report.beam_rows if r["rh_deg"] == rh}
            body.append(
                [f"{rh:g}", f"{at[fast[0]]['beams']:,}"]
                + [fmt_s(at[n]["scan_s"]) for n in fast]
                + [fmt_s(at[n]["ray_casting_s"]) for n in fast]
                + [fmt_s(at[REFERENCE]["scan_s"], True), ratio(at[fast[0]]["speedup_vs_ray_cast"], True)]
            )
        h = report.beam_rows[0]
        tables.append(
            (
                f"Scan time against beams (default world, {h['detail']} detail, {h['zone']} pose; placement to "
                "PLY written; scene.ray_cast ~ from its per-ray time)",
                headers,
                body,
            )
        )
    if report.level_rows:
        headers = (
            ["detail", "triangles (world)", "triangles (crop)"]
            + [f"{n} scan" for n in fast]
            + [f"{n} cast" for n in fast]
            + ["scene.ray_cast us/ray"]
        )
        body = []
        for detail in cfg.details:
            at = {r["backend"]: r for r in report.level_rows if r["detail"] == detail}
            if not at:
                continue
            body.append(
                [detail, f"{at[fast[0]]['triangles']:,}", f"{at[fast[0]]['crop_triangles']:,.0f}"]
                + [fmt_s(at[n]["scan_s"]) for n in fast]
                + [fmt_s(at[n]["ray_casting_s"]) for n in fast]
                + [f"{at[REFERENCE]['us_per_ray']:.0f}"]
            )
        tables.append(
            (
                "Scan time against triangles (default world detail levels, medians over the poses)",
                headers,
                body,
            )
        )
    if report.object_rows:
        headers = (
            ["objects", "triangles"]
            + [f"{n} scan" for n in fast]
            + [f"{n} cast" for n in fast]
            + ["scene.ray_cast us/ray", "scene.ray_cast scan", f"{fast[0]} x ray_cast"]
        )
        body = []
        for count in cfg.object_counts:
            at = {r["backend"]: r for r in report.object_rows if r["world"] == f"{count} rocks/trees"}
            body.append(
                [f"{at[fast[0]]['objects']:,}", f"{at[fast[0]]['triangles']:,}"]
                + [fmt_s(at[n]["scan_s"]) for n in fast]
                + [fmt_s(at[n]["ray_casting_s"]) for n in fast]
                + [
                    f"{at[REFERENCE]['us_per_ray']:.0f}",
                    fmt_s(at[REFERENCE]["scan_s"], True),
                    ratio(at[fast[0]]["speedup_vs_ray_cast"], True),
                ]
            )
        tables.append(
            (
                "Scan time against objects (terrain + N rocks and trees, each its own mesh object; one pose, "
                "full r_h = 1 deg scan, placement to PLY written)",
                headers,
                body,
            )
        )
    return tables


# =============================================================================================
# targets


def targets(report: "Report", cfg) -> list[tuple[str, bool | None, str]]:
    """(goal, met (None: not measured in this run), figures) for each goal of issue 5."""
    out = []
    default = cfg.fast_backends[0]
    head = report.headline
    if head is not None:
        runs = head["runs"]
        ref, mine = runs[REFERENCE][0], runs[default][0]
        agree, e2e = runs[default][2], runs[default][3]
        speed = ref.total / mine.total
        out.append(
            (
                f"full r_h = 1 deg scan with '{default}', placement to PLY, >= {SPEEDUP_TARGET:g}x faster than "
                "scene.ray_cast (same world and pose)",
                speed >= SPEEDUP_TARGET,
                f"{mine.total:.3f} s vs {ref.total:.1f} s = {speed:,.0f}x (default world, {head['detail']} "
                f"detail, {head['zone']} pose, measured)",
            )
        )
        labels, ranges = agree.labels_same / agree.rays, agree.ranges_ok / agree.rays
        worst = min(labels, ranges, e2e["e2e_label_agreement"], e2e["e2e_range_agreement"])
        out.append(
            (
                f">= {100 * AGREEMENT_TARGET:g}% identical labels, ranges within 1e-4 m (noise off), that scan",
                worst >= AGREEMENT_TARGET,
                f"same rays: labels {100 * labels:.4f}%, ranges {100 * ranges:.4f}% of {agree.rays:,} beams, "
                f"max |dr| {agree.max_range_diff_m:.1e} m, {agree.disagreements} disagreements of which "
                f"{agree.reference_wrong} scene.ray_cast's errors and {agree.backend_wrong} {default}'s by "
                f"exact brute force; as written (own placements, {e2e['placement_diff_m']:.1e} m apart): labels "
                f"{100 * e2e['e2e_label_agreement']:.4f}%, ranges {100 * e2e['e2e_range_agreement']:.4f}%",
            )
        )
    else:
        out.append(
            (
                f"full r_h = 1 deg scan >= {SPEEDUP_TARGET:g}x faster than scene.ray_cast",
                None,
                "not measured in --quick (needs one full scene.ray_cast scan of the default world)",
            )
        )
    if report.test_world:
        rows = {r["backend"]: r for r in report.test_world}
        t = rows[default]
        out.append(
            (
                "(test world, for the record) same scan and comparison",
                None,
                f"{t['scan_s']:.3f} s vs {rows[REFERENCE]['scan_s']:.2f} s = {t['speedup_vs_ray_cast']:,.0f}x; "
                f"labels {percent(t['label_agreement'])}, ranges {percent(t['range_agreement'])}",
            )
        )
    fine = [r for r in report.beam_rows if r["backend"] == default and r["rh_deg"] == FINE_RH]
    if fine:
        f = fine[0]
        prep = f["extract_s"] + f["crop_s"] + f["build_s"]
        out.append(
            (
                f"r_h = {FINE_RH:g} deg scan ({f['beams']:,} beams), placement to PLY written, "
                f"< {FINE_SCAN_TARGET_S:g} s once the scene is extracted",
                f["scan_s"] < FINE_SCAN_TARGET_S,
                f"{f['scan_s']:.3f} s (median of {f['runs']}); apart: whole-world extraction {f['extract_s']:.3f} s"
                f" + crop {f['crop_s']:.3f} s + {default} build {f['build_s']:.3f} s = {prep:.3f} s",
            )
        )
    if len(report.object_rows) >= 2:
        mine = [r for r in report.object_rows if r["backend"] == default]
        refs = [r for r in report.object_rows if r["backend"] == REFERENCE]
        growth = mine[-1]["scan_s"] / mine[0]["scan_s"]
        ref_growth = refs[-1]["us_per_ray"] / refs[0]["us_per_ray"]
        out.append(
            (
                f"scan time flat in the number of objects (here: at most {FLAT_TARGET:g}x for "
                f"{mine[-1]['objects'] / mine[0]['objects']:.0f}x the objects)",
                growth <= FLAT_TARGET,
                f"'{default}' {mine[0]['scan_s']:.3f} -> {mine[-1]['scan_s']:.3f} s ({growth:.2f}x) from "
                f"{mine[0]['objects']:,} to {mine[-1]['objects']:,} objects (and {mine[0]['triangles']:,} -> "
                f"{mine[-1]['triangles']:,} triangles); scene.ray_cast's time a ray {ref_growth:.1f}x",
            )
        )
    if report.analytic:
        worst = max(r["analytic_max_m"] for r in report.analytic)
        wrong = sum(r["analytic_wrong"] for r in report.analytic)
        out.append(
            (
                f"range error against the analytic primitives <= {ANALYTIC_TARGET_M:g} m for every backend",
                worst <= ANALYTIC_TARGET_M and wrong == 0,
                ", ".join(f"{r['backend']} {r['analytic_max_m']:.1e} m" for r in report.analytic)
                + f"; {wrong} rays labelled wrong",
            )
        )
    return out


def format_targets(items) -> str:
    body = [
        [("met" if ok else "NOT MET") if ok is not None else "-", goal, figures]
        for goal, ok, figures in items
    ]
    return "\n== Targets (issue 5)\n" + "\n".join(f"[{m:>7}] {g}\n          {f}" for m, g, f in body)


# =============================================================================================
# CSV, chart, markdown (written together, all or none)


def write_bench_files(rows: list[dict], tables, out_dir: Path) -> tuple[Path, Path, Path]:
    """bench.csv, bench.png and scaling.md, all three or none."""
    from .core.io.files import atomic_outputs

    paths = (out_dir / "bench.csv", out_dir / "bench.png", out_dir / "scaling.md")
    with atomic_outputs(*paths) as (tmp_csv, tmp_png, tmp_md):
        tmp_csv.write_text(bench_csv_text(rows))
        draw_chart(rows, tmp_png)
        tmp_md.write_text(markdown_text(tables))
    return paths


def _cell(value):
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.9g}"
    return value


def bench_csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row.get(k, "")) for k in CSV_COLUMNS})
    return buf.getvalue()


def draw_chart(rows: list[dict], path: Path) -> Path:
    """Time per full scan (log x) against error (log y), one point per backend (marker) and
    detail level (colour): left, the share of rays disagreeing with scene.ray_cast; right,
    the terrain RMS height error against the analytic heightfield."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    summary = [r for r in rows if r["section"] == "detail"]
    floor = 1e-6
    fig = Figure(figsize=(13, 5.6), dpi=110)
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    markers = {"embree": "o", "bvh": "s", REFERENCE: "^"}
    details = [d for d in ("low", "default", "high") if any(r["detail"] == d for r in summary)]
    colours = dict(zip(("low", "default", "high"), ("tab:green", "tab:blue", "tab:purple")))
    for r in summary:
        name = "ray_cast" if r["backend"] == REFERENCE else r["backend"]
        label = f"{name} {r['detail']}" + (" ~" if r["estimated"] else "")
        style = dict(
            marker=markers.get(r["backend"], "D"), color=colours.get(r["detail"], "k"), s=55, zorder=3
        )
        x = r["scan_s"]
        y_left = floor if r["backend"] == REFERENCE else max(1.0 - r["range_agreement"], floor)
        # the first fast backend is labelled on its left, the others on their right
        before = r["backend"] == "embree"
        offset = (-7 if before else 7, -12 + 8 * details.index(r["detail"]))
        for ax, y in ((left, y_left), (right, r["terrain_rms_m"])):
            ax.scatter([x], [y], **style)
            ax.annotate(
                label,
                (x, y),
                textcoords="offset points",
                xytext=offset,
                fontsize=7,
                ha="right" if before else "left",
            )
    worst = max([1.0 - r["range_agreement"] for r in summary if r["backend"] != REFERENCE] + [floor])
    left.set_ylim(floor / 3, max(worst * 5, 1e-3))
    left.axhline(floor, color="0.6", lw=0.8, ls="--")
    left.axhline(1.0 - AGREEMENT_TARGET, color="tab:red", lw=0.8, ls=":")
    left.text(
        0.02,
        1.0 - AGREEMENT_TARGET,
        " target: at most 1e-4 (99.99% agreement)",
        fontsize=7,
        color="tab:red",
        va="bottom",
        transform=left.get_yaxis_transform(),
    )
    left.text(
        0.98,
        0.02,
        "no disagreement: plotted at 1e-6 (dashed); scene.ray_cast is the reference",
        fontsize=7,
        color="0.35",
        ha="right",
        va="bottom",
        transform=left.transAxes,
    )
    left.set_ylabel("share of rays whose label or range (> 1e-4 m) differs from scene.ray_cast")
    right.set_ylabel("terrain RMS height error vs analytic heightfield (m)")
    times = [r["scan_s"] for r in summary] or [1.0]
    for ax, title in (
        (left, "agreement with scene.ray_cast"),
        (right, "terrain height error by detail level"),
    ):
        ax.set_xscale("log")
        ax.set_xlim(min(times) / 8, max(times) * 8)  # room for the labels either side
        ax.set_yscale("log")
        ax.set_xlabel("time per full r_h = 1 deg scan, placement to PLY written (s)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
    handles = [
        Line2D([], [], ls="", marker=m, color="0.3", label=backend_title(b))
        for b, m in markers.items()
        if any(r["backend"] == b for r in summary)
    ]
    handles += [Line2D([], [], ls="", marker="o", color=colours[d], label=f"{d} detail") for d in details]
    right.legend(
        handles=handles, fontsize=7, loc="center", bbox_to_anchor=(0.55, 0.68)
    )  # clear of the points
    fig.suptitle(
        "wildscan bench: time against error per backend and detail level "
        "(default world, medians over the poses; ~ = scene.ray_cast extrapolated)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(str(path), format="png")
    return path


def markdown_text(tables) -> str:
    return "\n\n".join(f"**{title}**\n\n{markdown_table(h, b)}" for title, h, b in tables) + "\n"


# =============================================================================================
# the command


@dataclass
class BenchConfig:
    seed: int
    details: tuple[str, ...]
    fast_backends: tuple[str, ...]
    runs: int
    reference_rays: int
    out: Path
    quick: bool

    @property
    def all_backends(self) -> tuple[str, ...]:
        return (REFERENCE, *self.fast_backends)

    @property
    def full_reference(self) -> bool:
        """Time one FULL scene.ray_cast scan of the default world (~50 s; not in --quick)."""
        return not self.quick

    @property
    def headline_detail(self) -> str:
        return "default" if "default" in self.details else self.details[0]

    @property
    def beam_steps(self) -> tuple[float, ...]:
        return QUICK_BEAM_STEPS if self.quick else BEAM_STEPS

    @property
    def object_counts(self) -> tuple[int, ...]:
        return QUICK_OBJECT_COUNTS if self.quick else OBJECT_COUNTS

    @property
    def terrain_rays(self) -> int:
        return QUICK_TERRAIN_RAYS if self.quick else TERRAIN_RAYS

    @property
    def analytic_rh(self) -> float:
        return 6.0 if self.quick else 4.0


@dataclass
class Report:
    out: Callable[[str], None] = print
    rows: list[dict] = field(default_factory=list)
    test_world: list[dict] = field(default_factory=list)
    analytic: list[dict] = field(default_factory=list)
    level_rows: list[dict] = field(default_factory=list)
    beam_rows: list[dict] = field(default_factory=list)
    object_rows: list[dict] = field(default_factory=list)
    poses: list = field(default_factory=list)
    headline: dict | None = None

    def say(self, text: str) -> None:
        self.out(text)

    def add_rows(self, rows: list[dict]) -> None:
        self.rows += rows


def add_bench_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    p.add_argument(
        "--seed", default="0", metavar="S", help="world seed, a whole number from 0 to 2147483647 (default 0)"
    )
    p.add_argument(
        "--details",
        default=None,
        metavar="LIST",
        help="detail levels of the default world, comma-separated from low, default, high "
        "(default: low,default,high; with --quick: low)",
    )
    p.add_argument(
        "--backends",
        default=None,
        metavar="LIST",
        help="fast backends to compare, comma-separated from auto, embree, bvh (default: every one "
        "available here); scene.ray_cast (blender) is always measured: ratios are against it",
    )
    p.add_argument(
        "--runs",
        default=None,
        metavar="N",
        help=f"runs per timing, the median is reported, 1..50 (default {DEFAULT_RUNS}; --quick {QUICK_RUNS})",
    )
    p.add_argument(
        "--reference-rays",
        default=None,
        metavar="N",
        help="rays per pose cast with scene.ray_cast where its full-scan time is extrapolated, 100..194400 "
        f"(default {DEFAULT_REFERENCE_RAYS}; --quick {QUICK_REFERENCE_RAYS}); one full scene.ray_cast "
        "scan of the test world and one of the default world are always timed whole (not in --quick)",
    )
    p.add_argument(
        "--out",
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"directory for bench.csv, bench.png and scaling.md (default {DEFAULT_OUT})",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run in well under a minute: low detail, 2 poses, 1 run, small subsets, no full "
        "scene.ray_cast scan of the default world",
    )


def _names(text: str, option: str) -> list[str]:
    names = [n.strip() for n in str(text).split(",")]
    if not all(names):
        raise UserError(f"{option} must be a comma-separated list without empty entries, got {text!r}")
    return names


def config_from_args(args) -> BenchConfig:
    """Check every option before anything runs (UserError names what is wrong)."""
    from .core.worldplan import DETAILS, check_seed
    from .raycast.select import missing_reason, resolve_backend

    seed = check_seed(args.seed)
    quick = bool(getattr(args, "quick", False))
    details = _names(args.details, "--details") if args.details else (["low"] if quick else list(DETAILS))
    for d in details:
        if d not in DETAILS:
            raise UserError(f"--details must list levels from {', '.join(DETAILS)}, got {d!r}")
    fast: list[str] = []
    for name in _names(args.backends, "--backends") if args.backends else ["embree", "bvh"]:
        if name not in ("auto", "embree", "bvh", REFERENCE):
            raise UserError(f"--backends must list names from auto, embree, bvh, blender, got {name!r}")
        if name == "auto":
            name = resolve_backend("auto", notify=None)
        elif args.backends and name != REFERENCE and missing_reason(name):
            raise UserError(f"--backends {name}: not available in this Python ({missing_reason(name)})")
        if name != REFERENCE and name not in fast and missing_reason(name) is None:
            fast.append(name)
    if not fast:
        raise UserError(
            "--backends must name at least one fast backend (embree or bvh) to compare with scene.ray_cast"
        )
    runs = (
        whole_number(args.runs, "runs", 1, 50)
        if args.runs is not None
        else (QUICK_RUNS if quick else DEFAULT_RUNS)
    )
    ref_rays = (
        whole_number(args.reference_rays, "reference_rays", 100, 194_400)
        if args.reference_rays is not None
        else (QUICK_REFERENCE_RAYS if quick else DEFAULT_REFERENCE_RAYS)
    )
    return BenchConfig(
        seed, tuple(dict.fromkeys(details)), tuple(fast), runs, ref_rays, output_directory(args.out), quick
    )


def run_bench_command(args, in_blender: bool = False, out: Callable[[str], None] | None = None) -> int:
    """`wildscan bench`: every measurement above, printed, with bench.csv, bench.png and
    scaling.md written to --out. Works the same inside Blender (it builds in scenes of its own)."""
    from .viz import have_matplotlib

    if not have_matplotlib():
        raise UserError(
            "wildscan bench draws its chart with matplotlib (pip install matplotlib); "
            "it is not installed here"
        )
    cfg = config_from_args(args)  # creates --out last, once every option is known good
    report = Report(out or _print_flush)
    start = time.perf_counter()
    report.say(
        f"wildscan bench{' --quick' if cfg.quick else ''}: seed {cfg.seed}, details {','.join(cfg.details)}, "
        f"backends {', '.join(backend_title(n) for n in cfg.all_backends)}, median of {cfg.runs} run(s); "
        f"noise off"
    )
    with tempfile.TemporaryDirectory(dir=cfg.out, prefix=".bench-scans-") as tmp:
        tmp = Path(tmp)
        bench_test_world(cfg, report, tmp)
        bench_analytic(cfg, report)
        bench_world_levels(cfg, report, tmp)
        bench_objects(cfg, report, tmp)
    tables = scaling_tables(report, cfg)
    for title, headers, body in tables:
        report.say(f"\n== {title}\n{text_table(headers, body)}")
    report.say(format_targets(targets(report, cfg)))
    csv_path, png_path, md_path = write_bench_files(report.rows, tables, cfg.out)
    report.say(
        f"\nwrote {csv_path}\nwrote {png_path}\nwrote {md_path} (the scaling tables in markdown)\n"
        f"bench finished in {time.perf_counter() - start:.0f} s"
    )
    return 0


def _print_flush(text: str) -> None:
    print(text, flush=True)


# ---------------------------------------------------------------------------------------------
# synthetic scenes with many objects (the scaling-with-objects table)


def build_many_objects_scene(
    n_objects: int,
    seed: int = 0,
    half_size: float = 50.0,
    scene=None,
    collection_name: str = BENCH_COLLECTION,
):
    """Terrain plus `n_objects` rocks and trees (each its own tagged mesh object) in a
    generated collection of `scene` (default: the active scene). Returns the collection."""
    import bpy

    from .core.rng import stage_rng
    from .core.testworld_plan import cone, cylinder, grid_heightfield, merge, uv_sphere
    from .world.mesh import mesh_object, wildscan_collection

    scene = scene or bpy.context.scene
    coll = wildscan_collection(collection_name, parent=scene.collection)
    rng = stage_rng(seed, "bench scene")
    xs = ys = np.arange(-half_size, half_size + 0.5, 1.0)
    heights = 0.3 * np.sin(xs[None, :] / 7.0) * np.cos(ys[:, None] / 9.0)
    terrain = grid_heightfield(xs, ys, heights)
    mesh_object("bench terrain", *terrain, coll, "terrain", 1)
    xy = rng.uniform(-half_size + 2, half_size - 2, size=(4 * n_objects, 2))
    # keep the poses' surroundings free so every placement succeeds
    poses = np.array([p[:2] for p in DEFAULT_POSES])
    far = np.min(np.linalg.norm(xy[:, None, :] - poses[None], axis=2), axis=1) > 3.0
    xy = xy[far][:n_objects]
    for i, (x, y) in enumerate(xy.tolist()):
        z = 0.3 * math.sin(x / 7.0) * math.cos(y / 9.0)
        if i % 2:
            r = float(rng.uniform(0.2, 0.6))
            mesh_object(
                f"bench rock {i}", *uv_sphere(r, 8, 12, center=(x, y, z + 0.5 * r)), coll, "rock", i + 2
            )
        else:
            h = float(rng.uniform(2.0, 4.0))
            trunk = cylinder(0.15, h, 12, base=(x, y, z))
            mesh_object(f"bench trunk {i}", *trunk, coll, "trunk", i + 2)
            top = merge([cone(1.0, 2.0, 12, base=(x, y, z + h))])
            mesh_object(f"bench top {i}", *top, coll, "treetop", i + 2)
    return coll
