"""Suite "casters" (`wildscan bench --suite casters`): float32 ray casters side by side on
the same triangles and rays, in one run.

The triangles: the default world of `--seed` (porous vegetation, the default biome), whole,
as a dataset worker holds it, sealed (padding.pad_triangles) once and shared by every
candidate: so "build" is each caster's own cost, the upload of the padded triangles and its
BVH (built on the first cast where the caster builds lazily). The rays: a full r_h = 1 deg
Hokuyo scan and an os1-64 frame from the world's first valid pose.

Per candidate: build time; its first hits of each ray set (the caster alone, `_first_hits`:
float32 in, triangle, t, u, v out) as ms and rays per second on one thread and, where the
binding lets two threads cast at once, on two; the peak memory the build adds (the kernel's
high-water mark, reset before the build on Linux; each build measured in a Python process of
its own, where an earlier build's freed memory cannot hide its peak); and whether both scans, fed through the
float64 settling and refinement (refine.RefiningBackend, settle.py), are the same PLY bytes
as with the reference, embreex's item-by-item upload (the metadata's backend name set to
embree for all). A candidate whose module is missing gets a row saying so and how to install
it; one that fails gets a row with its error.
"""

from __future__ import annotations

import gc
import hashlib
import os
import statistics
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .caster_table import CANDIDATES, REFERENCE, missing
from .measure import timed
from .report import text_table

RUNS, QUICK_RUNS = 5, 1
BUILD_ROUNDS = 3  # each caster built this many times, in turns, each in a process of its own
FRAME = "leveled"
HOKUYO_RH = 1.0
DEVICES = (("hokuyo", "utm30lx-ew", HOKUYO_RH), ("os1-64", "os1-64", None))
REALISTIC, REALISTIC_RH = "realistic", 2.0  # a realistic Hokuyo scan, compared for bytes only


# -- memory ---------------------------------------------------------------------------------


def _status_kb(key: str) -> int | None:
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def reset_peak() -> int | None:
    """Reset the kernel's peak-RSS mark (Linux: /proc/self/clear_refs "5") and return the
    current RSS in kB, or None where that cannot be done."""
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
    except OSError:
        return None
    return _status_kb("VmRSS")


def peak_added_mb(base_kb: int | None) -> float | None:
    high = _status_kb("VmHWM")
    return None if base_kb is None or high is None else (high - base_kb) / 1024


# -- the rays and the scans -----------------------------------------------------------------


@dataclass
class RaySet:
    name: str
    sensor: object
    origin: np.ndarray  # local (offset subtracted), broadcast to every ray
    dirs: np.ndarray
    cast_range: float


def ray_sets(geometry, pose, z_start, reference) -> list[RaySet]:
    """Each device's full-frame rays from the pose, as run_scan casts them."""
    from ..core.scan import NOISE_MARGIN_SIGMAS, run_scan
    from ..core.sensors import SensorConfig, device_named, rotated_beam_directions
    from ..raycast.refine import prepare_rays

    out = []
    for name, preset, rh in DEVICES:
        device = device_named(preset)
        settings = {} if rh is None else {"rh_deg": rh}
        sensor = SensorConfig.for_device(device, **settings).validate()
        placement = run_scan(reference, pose, sensor, FRAME, z_start).placement
        dirs = rotated_beam_directions(placement.rotation, sensor.rh_deg, device)
        local, dirs = prepare_rays(placement.optical_centre, dirs, geometry.offset)
        cast_range = sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma
        out.append(RaySet(name, sensor, local, dirs, cast_range))
    return out


def scan_sha(backend, pose, sensor, z_start, directory: Path, name: str) -> str:
    """SHA-256 of the PLY of one scan through `backend` (metadata's backend: embree)."""
    from ..core.io.ply import write_scan_files
    from ..core.scan import run_scan

    result = run_scan(backend, pose, sensor, FRAME, z_start)
    metadata = dict(result.metadata, backend="embree")
    ply, _ = write_scan_files(directory / f"{name}.ply", result.cloud, metadata)
    return hashlib.sha256(ply.read_bytes()).hexdigest()


def cast_once(backend, rays: RaySet, threads: int) -> float:
    """Seconds of the caster's first hits of the rays on `threads` threads (1 or 2)."""
    if threads == 1:
        return timed(backend._first_hits, rays.origin, rays.dirs, rays.cast_range)[1]
    how = next(c.two_threads for c in CANDIDATES if c.name == backend.bench_name)
    if how == "split":  # two Python threads, each half the rays (the binding releases the GIL)
        half = len(rays.dirs) // 2
        parts = ((rays.origin[:half], rays.dirs[:half]), (rays.origin[half:], rays.dirs[half:]))
        with ThreadPoolExecutor(2) as pool:
            return timed(lambda: list(pool.map(lambda p: backend._first_hits(*p, rays.cast_range), parts)))[1]
    with own_threads(backend, 2):
        return timed(backend._first_hits, rays.origin, rays.dirs, rays.cast_range)[1]


@contextmanager
def own_threads(backend, count: int):
    """The caster's own pool at `count` threads for a while (Open3D's nthreads, Dr.Jit's
    thread count), then back to one."""
    if backend.name == "mitsuba":
        import drjit as dr

        dr.set_thread_count(count)
        try:
            yield
        finally:
            dr.set_thread_count(1)
    else:
        backend.threads = count
        try:
            yield
        finally:
            backend.threads = 1


# -- the candidates: built one after another, timed in turns ---------------------------------


def build(candidate, geometry, settler):
    """(backend, row), or (None, row with why not)."""
    row = {"name": candidate.name, "what": candidate.what}
    why = missing(candidate)
    if why is not None:
        return None, dict(row, error=why)
    try:
        backend, figures = timed_build(candidate, geometry, settler)
    except Exception as exc:  # a candidate that cannot run here is a finding, not a crash
        return None, dict(row, error=f"failed: {type(exc).__name__}: {str(exc).splitlines()[0][:120]}")
    backend.bench_name = candidate.name
    return backend, dict(row, **figures)


def timed_build(candidate, geometry, settler):
    """(backend, {upload_s, build_s, peak_mb}): made from the shared settler, then one ray cast
    (a caster that builds its BVH lazily builds it then)."""
    gc.collect()
    base = reset_peak()
    start = time.perf_counter()
    backend = candidate.make(geometry, settler)
    uploaded = time.perf_counter()
    backend._first_hits(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]), 1.0)
    built = time.perf_counter()
    return backend, {"upload_s": uploaded - start, "build_s": built - start, "peak_mb": peak_added_mb(base)}


def builds_apart(settler, directory: Path, rounds: int) -> dict[str, dict]:
    """Each candidate's build figures measured in a Python process of its own (fresh memory:
    in one process a build reuses what an earlier one freed, which hides its peak), from the
    same padded triangles, `rounds` times in turns (the medians); {} where no such process
    can be started (inside Blender)."""
    import json
    import subprocess

    if Path(sys.executable).stem.lower().startswith("blender"):
        return {}
    soup = directory / "padded.npy"
    np.save(soup, settler.padded)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    runs: dict[str, list[dict]] = {}
    for _ in range(rounds):
        for candidate in CANDIDATES:
            if missing(candidate) is not None:
                continue
            answer = directory / f"{candidate.name}.json"
            answer.unlink(missing_ok=True)
            code = (
                "from wildscan.bench.casters import build_here; "
                + f"build_here({str(soup)!r}, {candidate.name!r})"
            )
            done = subprocess.run([sys.executable, "-c", code, str(answer)], env=env, capture_output=True)
            if done.returncode == 0 and answer.exists():
                runs.setdefault(candidate.name, []).append(json.loads(answer.read_text()))
    return {
        name: {key: statistics.median(r[key] for r in found) for key in found[0]}
        for name, found in runs.items()
    }


def build_here(soup_path: str, name: str) -> None:
    """In a process of its own (builds_apart): build candidate `name` over the padded soup and
    write its figures as JSON to the path in sys.argv[1]."""
    import json

    from ..raycast.geometry import from_triangles
    from ..raycast.settle import Settler

    padded = np.load(soup_path)
    geometry = from_triangles(padded)  # only the triangle count is read by a build from a settler
    settler = Settler(geometry, padded, (np.zeros((len(padded), 3)), np.zeros(len(padded))), padded)
    candidate = next(c for c in CANDIDATES if c.name == name)
    missing(candidate)  # imported first: an import is not the caster's build
    _, figures = timed_build(candidate, geometry, settler)
    Path(sys.argv[1]).write_text(json.dumps(figures))


def time_in_turns(built: list, sets: list[RaySet], runs: int) -> None:
    """Every candidate's casts, one run of each in turn, so load that comes and goes on the
    machine falls on all of them alike; the medians go into the rows."""
    times: dict = {}
    for _ in range(runs):
        for backend, row in built:
            two = next(c.two_threads for c in CANDIDATES if c.name == row["name"])
            for rays in sets:
                for threads in (1, 2) if two else (1,):
                    seconds = cast_once(backend, rays, threads)
                    times.setdefault((row["name"], rays.name, threads), []).append(seconds)
    for _, row in built:
        for rays in sets:
            one = statistics.median(times[(row["name"], rays.name, 1)])
            two = times.get((row["name"], rays.name, 2))
            row[rays.name] = {"rays": len(rays.dirs), "one_s": one, "two_s": two and statistics.median(two)}


def same_bytes(built: list, sets: list[RaySet], pose, z_start, directory: Path) -> None:
    """Each candidate's scans, PLY hashes compared with the reference's (the first built): one
    of each ray set, and a realistic Hokuyo scan (its sub-rays and normals; not timed here)."""
    from ..core.sensors import SensorConfig

    sensors = [(rays.name, rays.sensor) for rays in sets]
    sensors.append((REALISTIC, SensorConfig(rh_deg=REALISTIC_RH, model="realistic").validate()))
    reference = {}
    for backend, row in built:
        row["same"] = {}
        for name, sensor in sensors:
            sha = scan_sha(backend, pose, sensor, z_start, directory, f"{row['name']}-{name}")
            reference.setdefault(name, sha)
            row["same"][name] = sha == reference[name]


# -- the suite ------------------------------------------------------------------------------


def bench_casters(seed: int = 0, quick: bool = False, stream=None) -> list[dict]:
    from ..raycast.embree_backend import sealed
    from .devices import world_and_pose

    out = stream or sys.stdout
    detail, runs = ("low", QUICK_RUNS) if quick else ("default", RUNS)
    geometry, pose, z_start = world_and_pose(seed, detail)
    (_, prepared), shared_s = timed(sealed, geometry)
    with tempfile.TemporaryDirectory(prefix="wildscan-casters-") as tmp:
        apart = builds_apart(prepared, Path(tmp), BUILD_ROUNDS if not quick else 1)
        reference = next(c for c in CANDIDATES if c.name == REFERENCE).make(geometry, prepared)
        sets = ray_sets(geometry, pose, z_start, reference)
        built, rows = [], []
        for candidate in CANDIDATES:  # the reference first: the others' scans are compared with its
            backend, row = build(candidate, geometry, prepared)
            row.update(apart.get(candidate.name, {}))
            rows.append(row)
            if backend is not None:
                built.append((backend, row))
        time_in_turns(built, sets, runs)
        same_bytes(built, sets, pose, z_start, Path(tmp))
    print(
        f"Ray casters on the same triangles and rays: world of seed {seed} at {detail} detail (porous, "
        f"default biome), whole: {geometry.triangle_count:,} triangles, sealed once ({shared_s:.2f} s, "
        "shared); pose "
        f"({pose.x:.2f}, {pose.y:.2f}, {pose.yaw_deg:.1f}); "
        + ", ".join(f"{r.name} {len(r.dirs):,} rays" for r in sets)
        + f"; median of {runs} run(s); load average {os.getloadavg()[0]:.2f} at the end",
        file=out,
    )
    print(text_table(*_table(rows, sets)), file=out)
    print(
        "build: upload of the padded triangles + BVH (s), and peak: the memory the build adds (MB), each "
        "measured in a Python process of its own; cast: the caster's own first hits of the "
        "rays (float32), ms on 1 thread and Mrays/s on 1 | 2 threads ('-': the binding casts on one); "
        "same bytes: the PLY files of both "
        f"scans and of a realistic r_h = {REALISTIC_RH:g} deg Hokuyo scan identical to {REFERENCE}'s after "
        "the float64 settling",
        file=out,
    )
    for row in rows:
        print(f"  {row['name']}: {row['what']}" + (f" - {row['error']}" if "error" in row else ""), file=out)
    return rows


def _table(rows, sets):
    headers = ["caster", "build s", "upload s", "peak MB"]
    for rays in sets:
        headers += [f"{rays.name} ms", f"{rays.name} Mrays/s 1|2"]
    headers.append("same bytes")
    body = []
    for row in rows:
        if "error" in row:
            body.append([row["name"]] + ["-"] * (len(headers) - 2) + ["no: " + row["error"].split(" (")[0]])
            continue
        line = [row["name"], f"{row['build_s']:.2f}", f"{row['upload_s']:.2f}", _mb(row["peak_mb"])]
        for rays in sets:
            cast = row[rays.name]
            line += [f"{1000 * cast['one_s']:.1f}", _rates(cast)]
        line.append(
            "yes"
            if all(row["same"].values())
            else "NO: " + ", ".join(k for k, v in row["same"].items() if not v)
        )
        body.append(line)
    return headers, body


def _mb(value):
    return "-" if value is None else f"{value:.0f}"


def _rates(cast) -> str:
    one = cast["rays"] / cast["one_s"] / 1e6
    two = "-" if cast["two_s"] is None else f"{cast['rays'] / cast['two_s'] / 1e6:.2f}"
    return f"{one:.2f} | {two}"
