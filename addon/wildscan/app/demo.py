"""The demo, in two parts that say which is which. First the paper's island (`--layout paper
--biome paper`) of a seed with its aerial map and one labeled scan per zone with a preview
image each, the paper's section V in one command, its point counts beside the paper's.
Then the default world (the endless layout, the default biome, what `wildscan scan --seed`
scans): one scan per land cover found around the origin. It builds and scans with the very
functions `wildscan world` and `wildscan scan` use (app.world, app.scan)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from ..core.classes import BY_ID, CLASSES
from ..core.placement import Pose
from ..core.pointcloud import PointCloud
from ..core.sensors import SensorConfig
from .world import SavedWorld, StageProgress

DETAIL = "default"
# The paper's world (bare ground, the paper's elements): the demo is the paper's section V, and
# its point counts are the golden scans' (README's table, tools/docs_tables.py).
BIOME = "paper"
POSES_PER_ZONE = 3  # listed in the world's sidecar; the first valid one of each zone is scanned
# Point counts of the paper's r_h = 1 deg scans (Figs. 8-12), for comparison.
PAPER_POINTS = {"hills": 83_056, "lake": 63_998, "park": 60_669, "cave": 80_307, "forest": 85_479}
# What each zone's scan must show (what the demo is accepted on).
EXPECTED_CLASSES = {
    "hills": ("pole", "wire"),
    "forest": ("trunk", "treetop", "bush"),
    "park": ("table", "bench", "fence"),
    "lake": ("terrain",),
    "cave": ("terrain",),
    "trail": ("terrain",),
}


@dataclass
class ZoneScan:
    zone: str
    pose: Pose
    z_start: float | None
    cloud: PointCloud
    ply: Path

    @property
    def classes(self) -> list[str]:
        """Names of the classes in the scan, sorted."""
        return sorted(BY_ID[c].name for c in self.cloud.class_counts())

    @property
    def missing(self) -> list[str]:
        """Classes this zone's scan should show and does not."""
        present = set(self.classes)
        return [name for name in EXPECTED_CLASSES.get(self.zone, ()) if name not in present]


def prepare(out: str | os.PathLike, rh_deg: float) -> tuple[Path, SensorConfig]:
    """The output directory (created) and the sensor: `wildscan scan`'s defaults at `rh_deg`,
    so a zone's scan equals `wildscan scan` from the same pose byte for byte."""
    from ..core.io.files import output_directory

    sensor = SensorConfig(rh_deg=rh_deg).validate()
    return output_directory(out), sensor


def make_demo_world(seed: int, out: Path, progress: StageProgress | None = None) -> SavedWorld:
    from .world import make_world

    return make_world(
        seed, DETAIL, out / "world.blend", out / "map.png", POSES_PER_ZONE, progress, biome=BIOME
    )


def pose_label(pose: Pose, z_start: float | None) -> str:
    """A pose as the demo's table shows it: metres to a decimetre, yaw to a degree, and a
    mark for a pose that starts its lasers under a roof (the README's table uses it too)."""
    where = f"({pose.x:.1f}, {pose.y:.1f}, {pose.yaw_deg:.0f})"
    return where + (" z_start" if z_start is not None else "")


def first_pose_per_zone(poses: dict[str, list[dict]]) -> dict[str, dict]:
    return {zone: found[0] for zone, found in poses.items() if found}


def scan_zones(
    seed: int, world: SavedWorld, sensor: SensorConfig, backend: str = "auto", notify=print
) -> Iterator[ZoneScan]:
    """Scan the first valid pose of each zone of the world just built (the scene is
    extracted once for all of them); write each scan's PLY, sidecar and preview PNG."""
    from ..raycast.extract import extract_scene
    from ..viz.preview import render_preview
    from .scan import scan_current_scene, write_scan

    geometry = extract_scene()
    for zone, p in first_pose_per_zone(world.poses).items():
        pose = Pose(p["x"], p["y"], p["yaw"])
        z_start = p.get("z_start")
        result = scan_current_scene(
            pose, sensor, "leveled", z_start, backend, notify=notify, geometry=geometry
        )
        ply = world.blend.parent / f"scan_{zone}.ply"
        write_scan(ply, result, seed, str(world.blend), zone=zone)
        cloud = result.cloud
        where = f"({pose.x:.1f}, {pose.y:.1f}, {pose.yaw_deg:.0f} deg)"
        title = f"{zone}: {len(cloud):,} points, seed {seed}, pose {where}"
        render_preview(cloud, ply.with_suffix(".png"), title=title)
        yield ZoneScan(zone, pose, z_start, cloud, ply)


def classes_in_no_scan(scans: list[ZoneScan]) -> list[str]:
    seen = {c for s in scans for c in s.cloud.class_counts()}
    return [c.name for c in CLASSES if c.id not in seen]


# ---------------------------------------------------------------------------------------
# the second half: the default world (the endless layout, the default biome)


@dataclass
class CoverScan:
    cover: str  # the land cover the pose stands on
    pose: Pose
    cloud: PointCloud
    ply: Path
    tiles: str  # where its tiles came from (app/tiles.py TileCounts.text)

    @property
    def classes(self) -> list[str]:
        return sorted(BY_ID[c].name for c in self.cloud.class_counts())


def scan_endless(
    seed: int, out: Path, sensor: SensorConfig, backend: str = "auto", notify=print, cache=None
) -> Iterator[CoverScan]:
    """One scan per land cover of the default endless world around the origin (its default
    biome): the valid pose of each cover nearest the origin (nearest_cover_poses), scanned as
    `wildscan scan --seed S --pose X Y YAW` scans it (the tiles within reach, levels of
    detail on); each scan's PLY, sidecar and preview under `out`."""
    from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION
    from ..viz.preview import render_preview
    from .poses import TileBackends
    from .scan import endless_scan_geometry, scan_current_scene, write_scan
    from .tile_memory import process_memory
    from .tiles import TiledWorld

    world = TiledWorld(seed, DEFAULT_BIOME, DETAIL, DEFAULT_VEGETATION)
    memory = process_memory()
    backends = TileBackends(world, cache, memory)
    for cover, found in nearest_cover_poses(world, backends).items():
        pose = Pose(found["x"], found["y"], found["yaw"])
        geometry, counts = endless_scan_geometry(
            seed, pose, sensor, True, world.biome, world.vegetation, DETAIL, cache, memory, backend=backend
        )
        result = scan_current_scene(pose, sensor, "leveled", None, backend, notify=notify, geometry=geometry)
        ply = out / f"scan_{cover}.ply"
        write_scan(ply, result, seed, None, layout="endless", biome=world.biome, lod="on", cover=cover)
        where = f"({pose.x:.1f}, {pose.y:.1f}, {pose.yaw_deg:.0f} deg)"
        title = f"endless world, {cover}: {len(result.cloud):,} points, seed {seed}, pose {where}"
        render_preview(result.cloud, ply.with_suffix(".png"), title=title)
        yield CoverScan(cover, pose, result.cloud, ply, counts.text())


COVER_SEARCH_M = 300.0  # how far from the origin the demo looks for each land cover
COVER_STEP_M = 5.0  # spacing of the points it looks at
COVER_TRIES = 12  # nearest points of a cover tried before that cover is left out


def nearest_cover_poses(world, backends) -> dict[str, dict]:
    """For each land cover, the valid pose nearest the origin on it (yaw 0; points on a
    COVER_STEP_M lattice within COVER_SEARCH_M, the nearest COVER_TRIES tried): every cover
    the landscape has near the origin, in a few tiles' builds."""
    import numpy as np

    from .poses import placed_poses
    from .tiles import endless

    E = endless()
    axis = np.arange(-COVER_SEARCH_M, COVER_SEARCH_M + COVER_STEP_M / 2, COVER_STEP_M)
    gx, gy = (a.ravel() for a in np.meshgrid(axis, axis))
    near = np.argsort(np.hypot(gx, gy), kind="stable")
    cover = np.asarray(E.land_cover_at(world.seed, world.biome, gx, gy)).ravel()
    out = {}
    for k, name in enumerate(E.LAND_COVERS):
        tried = near[cover[near] == k][:COVER_TRIES]
        placed = placed_poses(backends, [(float(gx[i]), float(gy[i]), 0.0) for i in tried])
        found = next((p for p in placed if p is not None), None)
        if found is not None:
            out[name] = found
    return out
