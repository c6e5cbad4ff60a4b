"""Suite "weather" (`wildscan bench --suite weather`): each effect against the published curve
it comes from (core/effects/particles.py; docs/weather.md).

  wall    a flat wall facing the sensor at known ranges, WALL_RAYS beams at each: the share of
          its returns lost, measured through the very medium the scans use, beside the
          model's own curve (Weather.lost_fraction, the thin ray of the paper model; the
          realistic model's beam is lost only when all its sub-rays are); the largest range
          at which the wall still returns beside R_max of the range equation
  world   the default world of the seed from its first valid pose: points, points beyond
          10 m and the particle share per effect, paper model; the realistic scan's time in
          rain=25 beside clear air's (median of RUNS)
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from ..core.classes import PARTICLE_ID
from ..core.effects import Effects, Rays, Weather
from ..core.effects.weather import parse_settings
from ..core.hits import RayHits
from .report import text_table

SETTINGS = (
    "fog=40",
    "fog=200",
    "fog=1000",
    "rain=10",
    "rain=25",
    "rain=100",
    "dust=0.1",
    "dust=0.5",
    "snow=2",
    "snow=5",
    "rain=10,fog=200",
)
WALL_RANGES = (2.0, 5.0, 10.0, 15.0, 20.0, 25.0, 29.0)
WALL_RAYS = 20_000
WALL_CLASS = 6  # fence: any surface class will do
TOLERANCE = 0.05  # measured lost share within 5 points of the model's
RUNS = 3
CAST_RANGE = 30.09  # the scans' own: 30 m plus six sigma of the paper noise


class Wall:
    """A caster of one plane x = distance facing the sensor at the origin (the realistic
    model's `cast(origins, dirs, max_range, normals)`)."""

    def __init__(self, distance: float):
        self.distance = distance

    def __call__(self, origins, dirs, max_range, normals=False) -> RayHits:
        origins = np.broadcast_to(np.asarray(origins, dtype=np.float64), dirs.shape)
        with np.errstate(divide="ignore"):
            t = np.where(dirs[:, 0] > 0, (self.distance - origins[:, 0]) / dirs[:, 0], np.inf)
        hit = (t > 0) & (t <= max_range)
        n = len(dirs)
        return RayHits(
            distance=np.where(hit, t, np.inf),
            class_id=np.where(hit, WALL_CLASS, -1).astype(np.int16),
            instance=np.where(hit, 1, -1).astype(np.int32),
            normal=np.tile([-1.0, 0.0, 0.0], (n, 1)) if normals else None,
        )


def paper_lost(weather: Weather, distance: float, rays: int = WALL_RAYS) -> float:
    """The share of thin beams at a wall `distance` away that return no wall point."""
    dirs = np.tile([1.0, 0.0, 0.0], (rays, 1))
    hits = weather.medium(Rays(np.zeros(3), dirs, CAST_RANGE), Wall(distance)(np.zeros(3), dirs, CAST_RANGE))
    return float(np.mean(hits.class_id != WALL_CLASS))


def realistic_lost(weather: Weather, distance: float, rays: int = WALL_RAYS // 4) -> float:
    """The share of realistic beams (the UTM-30LX-EW's footprint) returning no wall echo."""
    from ..core.realism.footprint import subrays_around
    from ..core.realism.realistic import echo_points
    from ..core.sensors import SensorConfig

    sensor = SensorConfig(model="realistic", noise_sigma=0.0, max_range=30.0).validate()
    axis = np.tile([1.0, 0.0, 0.0], (rays, 1))
    e_u, e_v = np.tile([0.0, 1.0, 0.0], (rays, 1)), np.tile([0.0, 0.0, 1.0], (rays, 1))
    sub = subrays_around(axis, e_u, e_v, sensor.divergence_mrad)
    pts = echo_points(Wall(distance), np.zeros(3), sub, sensor, CAST_RANGE, Effects((weather,)))
    wall_beams = np.unique(pts.beam[pts.label == WALL_CLASS])
    return 1.0 - len(wall_beams) / rays


def wall_rows(settings=SETTINGS, ranges=WALL_RANGES) -> list[dict]:
    rows = []
    for text in settings:
        weather = Weather.of(parse_settings(text))
        model = weather.lost_fraction(np.array(ranges))
        for r, want in zip(ranges, model):
            got = paper_lost(weather, r)
            # the realistic beam: lost when each of its sub-rays is (independent draws), or past R_max
            sub = float(want) ** 5 if r <= weather.max_range else 1.0
            rows.append(
                {
                    "weather": text,
                    "range": r,
                    "model": float(want),
                    "paper": got,
                    "realistic_model": sub,
                    "realistic": realistic_lost(weather, r),
                }
            )
    return rows


def farthest_return(weather: Weather, step: float = 0.25) -> float:
    """The largest wall range (0.25 m steps to 30 m) at which a thin beam still returns the wall."""
    found = 0.0
    for r in np.arange(step, 30.0 + step / 2, step):
        if paper_lost(weather, float(r), 2000) < 1.0:
            found = float(r)
    return found


def range_rows(settings=SETTINGS) -> list[dict]:
    rows = []
    for text in settings:
        weather = Weather.of(parse_settings(text))
        rows.append(
            {
                "weather": text,
                "alpha": weather.extinction,
                "events_per_m": [c.key for c in weather.components],
                "r_max": weather.max_range,
                "farthest": farthest_return(weather),
            }
        )
    return rows


def world_rows(seed: int, settings=SETTINGS, runs: int = RUNS) -> tuple[list[dict], dict]:
    """Per effect, the paper scan of the default world's first valid pose; and the realistic
    scan's time in clear air and in rain=25."""
    from ..app.poses import plan_backend, valid_poses
    from ..app.scan import make_scene_backend, scan_effects
    from ..core.placement import Pose
    from ..core.scan import run_scan
    from ..core.sensors import SensorConfig
    from ..core.world import plan_world
    from ..raycast.from_plan import plan_geometry

    plan = plan_world(seed, "default")
    geometry = plan_geometry(plan)
    found = next(v[0] for v in valid_poses(plan, plan_backend(plan), 1).values() if v)
    pose = Pose(found["x"], found["y"], found["yaw"])
    sensor = SensorConfig(max_range=30.0).validate()
    backend = make_scene_backend("auto", pose, sensor, notify=lambda _t: None, geometry=geometry)
    rows = []
    for text in ("clear", *settings):
        weather = {} if text == "clear" else parse_settings(text)
        cloud = run_scan(
            backend, pose, sensor, z_start=found.get("z_start"), effects=scan_effects(weather, sensor)
        ).cloud
        far = cloud.range > 10.0
        rows.append(
            {
                "weather": text,
                "points": len(cloud),
                "beyond_10m": int(far.sum()),
                "particles": int((cloud.label == PARTICLE_ID).sum()),
                "max_surface_range": float(cloud.range[cloud.label != PARTICLE_ID].max()),
            }
        )
    realistic = SensorConfig(model="realistic", max_range=30.0).validate()
    timing = {}
    for text in ("clear", "rain=25"):
        effects = scan_effects({} if text == "clear" else parse_settings(text), realistic)
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            run_scan(backend, pose, realistic, z_start=found.get("z_start"), effects=effects)
            times.append(time.perf_counter() - t0)
        timing[text] = statistics.median(times)
    return rows, timing


def bench_weather(seed: int = 0, quick: bool = False, stream=None) -> dict:
    out = stream or sys.stdout

    def say(text: str) -> None:
        print(text, file=out, flush=True)

    settings = SETTINGS[:6] if quick else SETTINGS
    walls = wall_rows(settings)
    say("Wall at known ranges: share of returns lost, model curve beside measured (paper: thin ray;")
    say(f"realistic: 5 sub-rays, lost when all are), {WALL_RAYS:,} beams a range")
    table = [
        [
            w["weather"],
            f"{w['range']:g}",
            f"{w['model']:.3f}",
            f"{w['paper']:.3f}",
            f"{abs(w['paper'] - w['model']):.3f}",
            f"{w['realistic_model']:.3f}",
            f"{w['realistic']:.3f}",
        ]
        for w in walls
    ]
    say(text_table(["weather", "range m", "model", "paper", "|diff|", "real. model", "realistic"], table))
    worst = max(abs(w["paper"] - w["model"]) for w in walls)
    say(
        f"largest |paper - model|: {worst:.3f} "
        f"(target <= {TOLERANCE}: {'met' if worst <= TOLERANCE else 'NOT met'})"
    )
    ranges = range_rows(settings)
    say(
        "\nMaximum range: R_max of the range equation (R e^(alpha R) = 30 m) beside the farthest "
        "wall returned"
    )
    say(
        text_table(
            ["weather", "alpha 1/m", "R_max m", "farthest m"],
            [
                [r["weather"], f"{r['alpha']:.4f}", f"{r['r_max']:.2f}", f"{r['farthest']:.2f}"]
                for r in ranges
            ],
        )
    )
    result = {"wall": walls, "ranges": ranges, "worst": worst}
    if not quick:
        world, timing = world_rows(seed, settings)
        say(f"\nDefault world of seed {seed}, first valid pose, paper model, r_h = 1 deg, max range 30 m")
        say(
            text_table(
                ["weather", "points", "beyond 10 m", "particles", "max surface m"],
                [
                    [
                        w["weather"],
                        f"{w['points']:,}",
                        f"{w['beyond_10m']:,}",
                        f"{w['particles']:,}",
                        f"{w['max_surface_range']:.2f}",
                    ]
                    for w in world
                ],
            )
        )
        ratio = timing["rain=25"] / timing["clear"]
        say(
            f"realistic scan: clear {timing['clear']:.2f} s, rain=25 {timing['rain=25']:.2f} s, "
            f"{ratio:.2f}x (target <= 1.5x: {'met' if ratio <= 1.5 else 'NOT met'})"
        )
        result.update(world=world, timing=timing)
    return result
