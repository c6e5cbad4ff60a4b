"""The demo: the default world of a seed with its aerial map, and one labeled scan per zone
with a preview image each — the paper's section V in one command. It builds and scans
with the very functions `wildscan world` and `wildscan scan` use (app.world, app.scan)."""

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
