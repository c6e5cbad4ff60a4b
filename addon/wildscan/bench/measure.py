"""Measuring helpers the suites share: timing with the garbage collector out of the way,
agreement of two backends' hits (judged by exact brute force where they differ), one
scan timed by phase from placement to PLY written, and the bench's own scenes."""

from __future__ import annotations

import gc
import math
import statistics
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.backend import RayBackend
from .config import BENCH_COLLECTION, PHASES, RANGE_TOLERANCE, SCAN_RH

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
    return hits.rows(index)


def wrong_answers(geometry, origin, directions, max_range: float, hits, index: np.ndarray) -> int:
    """How many of the rays `index` a backend answered wrongly, by exact float64 brute force."""
    from ..raycast.reference import check_hits

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

    capabilities = frozenset()  # its cast takes no normals

    def __init__(self, backend: RayBackend):
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
        from ..core.sensors import rotated_beam_directions

        return rotated_beam_directions(self.result.placement.rotation, self.rh_deg)

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
    from ..core.sensors import SensorConfig

    return SensorConfig(rh_deg=rh_deg, noise_sigma=0.0).validate()


def timed_scan(backend: RayBackend, pose, z_start, rh_deg: float, ply_path: Path) -> ScanRun:
    """One full scan with run_scan (placement, sweep, labels, leveling) and its PLY + JSON
    written with write_scan_files, the way `wildscan scan` does it, timed by phase."""
    from ..core.io.ply import write_scan_files
    from ..core.scan import run_scan

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


def median_scan(backend: RayBackend, pose, z_start, rh_deg: float, ply_path: Path, runs: int) -> ScanRun:
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

    from ..blender.mesh import remove_generated

    remove_generated(BENCH_COLLECTION)
    bpy.data.scenes.remove(scene)


@contextmanager
def scene_context(scene):
    """Make `scene` the context scene for builders that use bpy.context.scene."""
    import bpy

    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
        yield


def reference_backend(scene) -> RayBackend:
    from ..raycast.blender_backend import BlenderRayCastBackend, scene_depsgraph

    return BlenderRayCastBackend(scene=scene, depsgraph=scene_depsgraph(scene))


def fast_backend(name: str, geometry) -> RayBackend:
    """A ready fast backend: Embree builds its BVH lazily on the first cast, so one ray is
    cast here and that build is counted with the backend's build time, not the first scan's."""
    from ..raycast.select import make_backend

    backend = make_backend(name, geometry=geometry, notify=None)
    backend.cast(geometry.offset, np.array([[0.0, 0.0, -1.0]]), 1.0)
    return backend


def crop_for(whole, pose, rh_deg: float = SCAN_RH):
    """What `wildscan scan` keeps of the world for this pose (app.scan.make_scene_backend)."""
    from ..app.scan import crop_radius

    return whole.cropped((pose.x, pose.y), crop_radius(noise_free(rh_deg)))


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


def finite_median(values) -> float:
    values = [v for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]
    return statistics.median(values) if values else math.nan


def pose_text(pose) -> str:
    return f"{pose.x:g} {pose.y:g} {pose.yaw_deg:g}"
