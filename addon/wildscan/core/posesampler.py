"""Scan poses for a dataset (numpy only): per-zone quotas or uniform over the world, a
minimum distance between the scans of one world, yaw uniform, every draw from a seeded
stream, so the same world and settings give the same poses on any machine and with any
number of workers.

A candidate is kept when the numpy footprint pre-check (`footprint_ok`) passes, it is at
least `min_distance` from every pose already kept in this world, and `accept` (the real
four-laser placement, given by the caller) says yes. Zones strategy: scan k of a world
belongs to the zone the interleaved quota order gives it (`scan_zones`); its candidates
are first that zone's reserved sites (WorldPlan.sites: the cave interior, the park's
fence, the power line ...), each with a uniform yaw, then uniform points of the zone's
cell. Uniform strategy: uniform points of the whole world; the zone is the cell it falls in.
A scan that finds no pose in MAX_CANDIDATES candidates is reported (NoPose), and its zone
is not tried again in that world.

Class-aware poses (`min_scans_with`, class -> share of a world's scans): that share of the scan
indices (spread evenly over them, so any prefix keeps it) draw their candidates near the
elements of the class instead (NEAR_MIN..NEAR_MAX metres from one, uniform yaw), so a rare class
(a table, a wire) is in that share of the scans at least, not confined to its zones. Their zone
is where the pose falls.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from . import detmath as dm
from .placement import Pose
from .rng import stage_rng
from .world import ZONES, WorldPlan, footprint_ok
from .world.geometry2d import inset

STRATEGIES = ("zones", "uniform")
MAX_CANDIDATES = 2000  # per scan: beyond this the zone (or world) has no room left
NEAR_MIN, NEAR_MAX = 2.0, 8.0  # m from an element of the class a class-aware pose is drawn near
NEAR = "near "  # the stream key (and NoPose zone) of the scans drawn near a class


@dataclass(frozen=True)
class ScanPose:
    zone: str
    x: float
    y: float
    yaw_deg: float
    kind: str  # the reserved site's kind ("inside cave", "near fence", ...) or "random"
    z_start: float | None = None

    @property
    def pose(self) -> Pose:
        return Pose(self.x, self.y, self.yaw_deg)

    def to_dict(self) -> dict:
        return {
            "zone": self.zone,
            "x": self.x,
            "y": self.y,
            "yaw": self.yaw_deg,
            "z_start": self.z_start,
            "kind": self.kind,
        }


@dataclass(frozen=True)
class NoPose:
    zone: str
    reason: str


def zone_quotas(weights: dict[str, float], count: int, names: tuple[str, ...] = ZONES) -> dict[str, int]:
    """Scans per zone (or land cover: `names` in their order): `count` shared in proportion to
    the weights (largest remainders, ties in the order of `names`)."""
    zones = [z for z in names if weights.get(z, 0) > 0]
    total = sum(weights[z] for z in zones)
    exact = {z: count * weights[z] / total for z in zones}
    quota = {z: math.floor(exact[z]) for z in zones}
    by_remainder = sorted(zones, key=lambda z: (-(exact[z] - quota[z]), names.index(z)))
    for z in by_remainder[: count - sum(quota.values())]:
        quota[z] += 1
    return quota


def scan_zones(weights: dict[str, float], count: int, names: tuple[str, ...] = ZONES) -> list[str]:
    """The zone of each scan index: zones interleaved in proportion to their quotas, so any
    prefix of a world's scans (a --limit run) already covers its zones fairly."""
    quota = zone_quotas(weights, count, names)
    keyed = [((j + 0.5) / q, names.index(z), z) for z, q in quota.items() for j in range(q)]
    return [z for _, _, z in sorted(keyed)]


def _rounded(rng: np.random.Generator, rect) -> tuple[float, float, float]:
    # rounded as the sidecars print poses, so the pose a user copies is the pose scanned
    x = round(float(rng.uniform(rect[0], rect[1])), 3)
    y = round(float(rng.uniform(rect[2], rect[3])), 3)
    return x, y, round(float(rng.uniform(0.0, 360.0)), 1) % 360.0


def _zone_candidates(plan: WorldPlan, zone: str) -> Iterator[ScanPose]:
    rng = stage_rng(plan.seed, f"dataset.poses.{zone}")
    for site in plan.sites:
        if site.zone == zone:
            yaw = round(float(rng.uniform(0.0, 360.0)), 1) % 360.0
            yield ScanPose(zone, site.x, site.y, yaw, site.kind, site.z_start)
    cell = inset(plan.layout.cells[zone], 1.0)
    while True:
        yield ScanPose(zone, *_rounded(rng, cell), "random")


def zone_at(plan: WorldPlan, x: float, y: float) -> str:
    for zone, (x0, x1, y0, y1) in plan.layout.cells.items():
        if x0 <= x <= x1 and y0 <= y <= y1:
            return zone
    return "world"


def _class_candidates(plan: WorldPlan, wildscan_class: str) -> Iterator[ScanPose]:
    """Poses NEAR_MIN..NEAR_MAX metres from a random element of the class (none: nothing)."""
    rng = stage_rng(plan.seed, f"dataset.poses.near.{wildscan_class}")
    elements = plan.elements_of(wildscan_class)
    if not elements:
        return
    anchors = [_anchor(plan, el) for el in elements]
    area = inset(plan.extent, 1.0)
    while True:
        ax, ay = anchors[int(rng.integers(len(elements)))]
        r = float(rng.uniform(NEAR_MIN, NEAR_MAX))
        s, c = dm.sincos(float(rng.uniform(0.0, 2.0 * math.pi)))
        x = round(min(max(ax + r * c, area[0]), area[1]), 3)
        y = round(min(max(ay + r * s, area[2]), area[3]), 3)
        yaw = round(float(rng.uniform(0.0, 360.0)), 1) % 360.0
        yield ScanPose(zone_at(plan, x, y), x, y, yaw, f"{NEAR}{wildscan_class}")


def _anchor(plan: WorldPlan, el) -> tuple[float, float]:
    """Where an element stands: its location, but for a mesh laid out in world coordinates
    (located at the origin: the terrain, the trail, the cave's rock faces, each wire span) the
    centre of its triangles' bounding box, not the world's origin."""
    if any(el.location):
        return float(el.location[0]), float(el.location[1])
    xy = plan.element_vertices(el)[:, :2]
    centre = (xy.min(axis=0) + xy.max(axis=0)) / 2.0
    return float(centre[0]), float(centre[1])


def class_scan_indices(targets: dict[str, float], count: int) -> dict[int, str]:
    """Scan index -> the class it is drawn near: ceil(share x count) indices a class, spread
    evenly, the classes in the order given (an index taken goes to the next free one)."""
    taken: dict[int, str] = {}
    for name, share in targets.items():
        wanted = min(count, math.ceil(share * count - 1e-9))
        for j in range(wanted):
            k = int((j + 0.5) * count / wanted)
            while k in taken and len(taken) < count:
                k = (k + 1) % count
            if len(taken) < count:
                taken[k] = name
    return taken


def _uniform_candidates(plan: WorldPlan) -> Iterator[ScanPose]:
    rng = stage_rng(plan.seed, "dataset.poses.uniform")
    area = inset(plan.extent, 1.0)
    while True:
        x, y, yaw = _rounded(rng, area)
        yield ScanPose(zone_at(plan, x, y), x, y, yaw, "random")


def _far_enough(c: ScanPose, kept: list[ScanPose], min_distance: float) -> bool:
    return all(dm.hypot(c.x - k.x, c.y - k.y) >= min_distance for k in kept)


def sample_poses(
    plan: WorldPlan,
    count: int,
    strategy: str,
    weights: dict[str, float],
    min_distance: float,
    accept: Callable[[ScanPose], bool],
    min_scans_with: dict[str, float] | None = None,
) -> list[ScanPose | NoPose]:
    """One entry per scan index 0..count-1: its pose, or why there is none. `min_scans_with`:
    class -> share of the scans drawn near that class's elements (module docstring)."""
    if strategy == "uniform":
        zones = ["world"] * count
        streams = {"world": _uniform_candidates(plan)}
    else:
        zones = scan_zones(weights, count)
        streams = {z: _zone_candidates(plan, z) for z in set(zones)}
    for k, name in class_scan_indices(min_scans_with or {}, count).items():
        zones[k] = NEAR + name
        streams.setdefault(zones[k], _class_candidates(plan, name))
    kept: list[ScanPose] = []
    out: list[ScanPose | NoPose] = []
    exhausted: dict[str, str] = {}
    for zone in zones:
        if zone in exhausted:
            out.append(NoPose(zone, exhausted[zone]))
            continue
        found = _first_valid(streams[zone], kept, min_distance, accept, plan)
        if found is None:
            where = "the world" if zone == "world" else f"zone {zone}"
            exhausted[zone] = (
                f"no valid pose left in {where}: {MAX_CANDIDATES} candidates in a row were off the "
                f"ground the robot can stand on or closer than {min_distance:g} m to another scan"
            )
            out.append(NoPose(zone, exhausted[zone]))
            continue
        kept.append(found)
        out.append(found)
    return out


def _first_valid(stream, kept, min_distance, accept, plan) -> ScanPose | None:
    for _ in range(MAX_CANDIDATES):
        c = next(stream, None)
        if c is None:  # a class the world has no element of
            return None
        if not footprint_ok(plan, c.x, c.y, c.yaw_deg, allow_pit=c.z_start is not None):
            continue
        if _far_enough(c, kept, min_distance) and accept(c):
            return c
    return None
