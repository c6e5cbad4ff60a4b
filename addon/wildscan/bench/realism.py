"""Suite "realism" (`wildscan bench --suite realism`): what the realistic sensor model and the
porous vegetation give, and what they cost, beside the paper model and the solid world.

  porosity   the share of horizontal beams through 3 m of crown, per tree kind (crowns of
             POROSITY_SEEDS worlds), and the sky seen from under the forest canopy
             (bench/porosity.py), against their goals
  echoes     a realistic scan of every zone's first valid pose: how many beams return 1, 2
             or 3 echoes, how many points are mixed, how many beams see a trunk behind crown
  speed      the same full r_h = 1 deg scans, placement to PLY written, paper beside
             realistic, as `wildscan scan` takes them (the world's ground cover included;
             median of RUNS; Blender-free plan geometry, the default backend), with the share
             of the realistic scan spent in the backend's cast; every zone against
             SPEED_TARGET_S
  footprint  the coarse-to-fine footprint (core/realism/coarse_footprint.py) against every sub-ray
             cast, per beam, at the same poses (bench/footprint_accuracy.py)
  build      the world of the seed built in Blender at default detail, porous beside solid
             (the worlds before porous vegetation): seconds, peak memory, objects,
             triangles (each in a fresh Python, so peak memory is the build's own)
"""

from __future__ import annotations

import functools
import json
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from .porosity import crown_gap_fractions, sky_fraction
from .report import text_table

POROSITY_SEEDS = 4
CROWN_TARGET = (0.20, 0.50)
SKY_TARGET = (0.15, 0.35)
SPEED_TARGET_S = 0.25  # s, a realistic full r_h = 1 deg scan, in every zone
RUNS = 3
DETAIL = "default"


def _within(value: float, bounds) -> str:
    return "met" if bounds[0] <= value <= bounds[1] else "NOT met"


def crown_rows(seed: int, seeds: int) -> list[dict]:
    """Gap fraction through 3 m of crown per tree kind, over the prototypes of `seeds` worlds."""
    rows = [r for s in range(seed, seed + seeds) for r in crown_gap_fractions(s, DETAIL)]
    out = []
    for kind in ("conifer", "broadleaf", "birch"):
        mine = [r for r in rows if r["tree"].rstrip("0123456789") == kind]
        rays = np.array([r["rays_3m"] for r in mine])
        gaps = np.array([r["gap_3m"] for r in mine])
        out.append(
            {
                "kind": kind,
                "trees": len(mine),
                "gap_3m": float((gaps * rays).sum() / rays.sum()),
                "gap_3m_min": float(gaps.min()),
                "gap_3m_max": float(gaps.max()),
                "gap_crown": float(np.mean([r["gap_crown"] for r in mine])),
            }
        )
    return out


def trunk_behind_crown(cloud) -> int:
    """Beams with a trunk point behind one of their crown points (a later echo)."""
    from ..core.classes import class_by_name

    beam = cloud.sweep.astype(np.int64) * 1080 + cloud.ring
    echo = cloud.extra["echo"]
    crown = cloud.label == class_by_name("treetop").id
    trunk = cloud.label == class_by_name("trunk").id
    first_crown = {}
    for b, e in zip(beam[crown], echo[crown]):
        first_crown[b] = min(e, first_crown.get(b, 9))
    return len({b for b, e in zip(beam[trunk], echo[trunk]) if b in first_crown and e > first_crown[b]})


class CastTimer:
    """A backend that adds up the seconds during which its `cast` runs (the rest of a scan is
    ours): wall-clock time with at least one cast under way, so casts on parallel threads
    (core/runtime/threads.py) are counted once."""

    def __init__(self, backend, clock=time.perf_counter):
        self.backend = backend
        self.name = backend.name
        self.capabilities = backend.capabilities
        self.seconds = 0.0
        self._clock = clock
        self._lock = threading.Lock()
        self._running = 0
        self._since = 0.0

    def cast(self, *args, **kwargs):
        with self._lock:
            if not self._running:
                self._since = self._clock()
            self._running += 1
        try:
            return self.backend.cast(*args, **kwargs)
        finally:
            with self._lock:
                self._running -= 1
                if not self._running:
                    self.seconds += self._clock() - self._since


@functools.lru_cache(maxsize=1)
def scene_and_poses(seed: int, zones: tuple[str, ...]):
    """(the plan geometry of `seed`'s world, the first valid pose of each of `zones`)."""
    from ..app.poses import plan_backend, valid_poses
    from ..core.world import plan_world
    from ..raycast.from_plan import plan_geometry

    plan = plan_world(seed, DETAIL)
    return plan_geometry(plan), valid_poses(plan, plan_backend(plan), 1, zones)


def scan_rows(seed: int, runs: int, zones=None) -> list[dict]:
    """Per zone: the paper and realistic scans of its first valid pose, timed placement to
    PLY written, and the realistic scan's echoes."""
    from ..app.scan import make_scene_backend, scan_effects, scene_cover
    from ..core.io.ply import write_scan_files
    from ..core.placement import Pose
    from ..core.scan import run_scan
    from ..core.sensors import SensorConfig
    from ..core.world import ZONES
    from .measure import gc_paused

    geometry, poses = scene_and_poses(seed, tuple(zones or ZONES))
    rows = []
    with tempfile.TemporaryDirectory(prefix="wildscan-realism-") as tmp:
        for zone, found in poses.items():
            if not found:
                continue
            p = found[0]
            pose = Pose(p["x"], p["y"], p["yaw"])
            row = {"zone": zone, "pose": (p["x"], p["y"], p["yaw"])}
            for model in ("paper", "realistic"):
                sensor = SensorConfig(model=model).validate()
                effects = scan_effects(None, sensor, scene_cover(geometry))
                backend = CastTimer(
                    make_scene_backend("auto", pose, sensor, notify=lambda _t: None, geometry=geometry)
                )
                times, casts = [], []
                # a first scan fills what a backend keeps for every later one (the settling
                # index: the world's build, not the scan's)
                run_scan(backend, pose, sensor, z_start=p.get("z_start"), effects=effects)
                for _ in range(runs):
                    with gc_paused():
                        backend.seconds = 0.0
                        t0 = time.perf_counter()
                        result = run_scan(backend, pose, sensor, z_start=p.get("z_start"), effects=effects)
                        write_scan_files(Path(tmp) / f"{zone}_{model}.ply", result.cloud, result.metadata)
                        times.append(time.perf_counter() - t0)
                        casts.append(backend.seconds)
                row[f"{model}_s"] = statistics.median(times)
                row[f"{model}_cast_s"] = statistics.median(casts)
                row[f"{model}_points"] = len(result.cloud)
            echoes = result.metadata["echoes"]
            beams = echoes["beams_by_echoes"]
            returned = sum(beams.values())
            row.update(
                beams_returning=returned,
                share_2=beams.get("2", 0) / max(returned, 1),
                share_3=beams.get("3", 0) / max(returned, 1),
                mixed=echoes["mixed_points"] / max(len(result.cloud), 1),
                trunk_behind_crown=trunk_behind_crown(result.cloud),
            )
            rows.append(row)
    return rows


def speed_goals(scans: list[dict]) -> list[str]:
    """One line per zone: its realistic full scan against SPEED_TARGET_S, met or not."""
    return [
        f"  realistic full scan, {r['zone']:<6} reference pose {r['realistic_s']:.3f} s "
        f"<= {SPEED_TARGET_S} s "
        f"({r['realistic_cast_s'] / r['realistic_s']:.0%} in the cast): "
        f"{'met' if r['realistic_s'] <= SPEED_TARGET_S else 'NOT met'}"
        for r in scans
    ]


# Peak memory: VmHWM, this process image's own high-water mark (ru_maxrss would also count
# the pages the bench process had when it forked this one).
_BUILD_SCRIPT = """
import json, resource, sys, time


def peak_mb():
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


from wildscan.app.world import build_in_scene
from wildscan.blender.scene_io import empty_scene
from wildscan.raycast.extract import extract_scene
empty_scene()
t0 = time.perf_counter()
plan = build_in_scene(int(sys.argv[1]), sys.argv[2], vegetation=sys.argv[3])
t1 = time.perf_counter()
geometry = extract_scene()
t2 = time.perf_counter()
c = plan.counts()
print(json.dumps({"build_s": t1 - t0, "plan_s": sum(plan.timings.get(s, 0) for s in plan.timings
    if not s.startswith("blender")), "extract_s": t2 - t1, "objects": c["objects"], "meshes": c["meshes"],
    "triangles": c["triangles"], "peak_mb": peak_mb()}))
"""


def build_rows(seed: int) -> list[dict]:
    """The world of `seed` built in Blender at default detail, porous and solid, each in a
    fresh Python (this one's, which must have bpy)."""
    rows = []
    for vegetation in ("solid", "porous"):
        done = subprocess.run(
            [sys.executable, "-c", _BUILD_SCRIPT, str(seed), DETAIL, vegetation],
            capture_output=True,
            text=True,
            check=False,
        )
        lines = [ln for ln in done.stdout.splitlines() if ln.startswith("{")]
        if done.returncode != 0 or not lines:
            rows.append({"vegetation": vegetation, "error": (done.stderr.strip().splitlines() or ["?"])[-1]})
            continue
        rows.append({"vegetation": vegetation, **json.loads(lines[-1])})
    return rows


def bench_realism(seed: int = 0, quick: bool = False, stream=None) -> dict:
    """Run every section, print its table and the goals; return what was measured."""
    stream = stream or sys.stdout

    def say(text: str) -> None:
        stream.write(text + "\n")
        stream.flush()

    say(f"wildscan bench --suite realism{' --quick' if quick else ''}: seed {seed}, detail {DETAIL}")
    crowns = crown_rows(seed, 1 if quick else POROSITY_SEEDS)
    say("\n== Crown porosity: horizontal beams through 3 m of crown that hit nothing (goal 20-50 %)")
    say(
        text_table(
            ["kind", "trees", "through 3 m", "min", "max", "through whole crown"],
            [
                [
                    r["kind"],
                    r["trees"],
                    f"{r['gap_3m']:.1%}",
                    f"{r['gap_3m_min']:.1%}",
                    f"{r['gap_3m_max']:.1%}",
                    f"{r['gap_crown']:.1%}",
                ]
                for r in crowns
            ],
        )
    )
    from ..core.world import plan_world
    from ..raycast.from_plan import plan_geometry

    skies = {}
    for vegetation in ("porous",) if quick else ("porous", "solid"):
        plan = plan_world(seed, DETAIL, vegetation=vegetation)
        skies[vegetation] = sky_fraction(plan, plan_geometry(plan), seed=seed)
    say("\n== Sky seen from under the forest canopy, zenith <= 60 deg, 1 m above the ground (goal 15-35 %)")
    say(
        text_table(
            ["vegetation", "points", "sky", "10th pct", "90th pct"],
            [
                [v, s["points"], f"{s['sky']:.1%}", f"{s['p10']:.1%}", f"{s['p90']:.1%}"]
                for v, s in skies.items()
            ],
        )
    )
    runs = 1 if quick else RUNS
    scans = scan_rows(seed, runs)
    say(
        f"\n== Full r_h = 1 deg scans, placement to PLY written (median of {runs}; 'in cast': the "
        "realistic scan's share in the backend's cast), and the realistic echoes"
    )
    say(
        text_table(
            [
                "zone",
                "paper",
                "realistic",
                "in cast",
                "paper pts",
                "realistic pts",
                "2 echoes",
                "3 echoes",
                "mixed",
                "trunk behind crown",
            ],
            [
                [
                    r["zone"],
                    f"{r['paper_s']:.3f} s",
                    f"{r['realistic_s']:.3f} s",
                    f"{r['realistic_cast_s'] / r['realistic_s']:.0%}",
                    f"{r['paper_points']:,}",
                    f"{r['realistic_points']:,}",
                    f"{r['share_2']:.1%}",
                    f"{r['share_3']:.1%}",
                    f"{r['mixed']:.1%}",
                    f"{r['trunk_behind_crown']:,} beams",
                ]
                for r in scans
            ],
        )
    )
    from ..core.world import ZONES
    from .footprint_accuracy import accuracy_rows, accuracy_table

    accuracy = accuracy_rows(*scene_and_poses(seed, tuple(ZONES)))
    say(
        "\n== The coarse-to-fine footprint against every sub-ray cast, per beam (clear air: "
        "bench/footprint_accuracy.py)"
    )
    say(text_table(*accuracy_table(accuracy)))
    builds = [] if quick else build_rows(seed)
    if builds:
        say(f"\n== The world of seed {seed} built in Blender at {DETAIL} detail (a fresh Python each)")
        say(
            text_table(
                ["vegetation", "build", "extract", "peak memory", "objects", "meshes", "triangles"],
                [
                    [
                        b["vegetation"],
                        b.get("error", f"{b.get('build_s', 0):.2f} s"),
                        f"{b.get('extract_s', 0):.2f} s",
                        f"{b.get('peak_mb', 0):,.0f} MB",
                        f"{b.get('objects', 0):,}",
                        b.get("meshes", 0),
                        f"{b.get('triangles', 0):,}",
                    ]
                    for b in builds
                ],
            )
        )
    say("\n== Goals")
    for r in crowns:
        say(
            f"  {r['kind']:<10} through 3 m of crown {r['gap_3m']:.1%} in 20-50 %: "
            f"{_within(r['gap_3m'], CROWN_TARGET)}"
        )
    porous_sky = skies["porous"]["sky"]
    say(f"  sky from under the forest canopy {porous_sky:.1%} in 15-35 %: {_within(porous_sky, SKY_TARGET)}")
    by_zone = {r["zone"]: r for r in scans}
    for line in speed_goals(scans):
        say(line)
    if "forest" in by_zone:
        f = by_zone["forest"]
        say(
            f"  forest: beams returning 2 or 3 echoes {f['share_2'] + f['share_3']:.1%}; trunk behind "
            "crown on "
            f"{f['trunk_behind_crown']:,} beams: {'met' if f['trunk_behind_crown'] > 0 else 'NOT met'}"
        )
    return {"crowns": crowns, "sky": skies, "scans": scans, "footprint": accuracy, "builds": builds}
