"""Full-precision hashes of what a world and its scans produce (a script: prints JSON).

tests/test_determinism.py runs it under forced instruction sets (numpy's, glibc's,
OpenBLAS's) and under QEMU as an older CPU (Embree's too), and wants the same output
everywhere. Blender-free: plan_world, raycast.from_plan.plan_geometry and Embree.

    python tests/helpers/determinism_probe.py [--seed S] [--detail D] [--rh DEG] [--zones a,b] [--drive]

--drive adds a short drive along the world's trail: moving, turning, the
continuous head, wind and noise on, both bags; every file it writes is hashed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import tempfile
from pathlib import Path

import numpy as np


def sha(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else np.ascontiguousarray(p).tobytes())
    return h.hexdigest()


def world_hashes(plan) -> dict[str, str]:
    """Every element's float64 world vertices unrounded (plan_hash rounds them to 10 um),
    faces and tags; the terrain grid; the reserved sites and levels."""
    elements = hashlib.sha256()
    for el in sorted(plan.elements, key=lambda e: e.name):
        elements.update(f"{el.name}|{el.wildscan_class}|{el.instance}|{el.stage}".encode())
        elements.update(plan.element_vertices(el).tobytes())
        elements.update(plan.prototypes[el.proto].faces.tobytes())
    sites = [(s.zone, s.x, s.y, s.yaw_deg, s.z_start) for s in plan.sites]
    return {
        "elements": elements.hexdigest(),
        "terrain grid": sha(plan.grid.xs, plan.grid.ys, plan.grid.z),
        "sites and levels": sha(json.dumps([sites, plan.water_z, plan.cave_level]).encode()),
    }


# The worlds `probe` planned (and hashed), for the drive of the same seed: under QEMU a
# second plan_world of the same world would be a minute of the emulated run for nothing new.
PLANNED: dict[tuple[int, str], object] = {}


def probe(seed: int, detail: str, rh: float, zones: list[str]) -> dict[str, str]:
    from wildscan.app.poses import valid_poses
    from wildscan.core.io.ply import write_scan_files
    from wildscan.core.placement import Pose
    from wildscan.core.scan import run_scan
    from wildscan.core.sensors import SensorConfig
    from wildscan.core.world import plan_world
    from wildscan.raycast.embree_backend import EmbreeBackend
    from wildscan.raycast.from_plan import plan_geometry
    from wildscan.raycast.select import make_backend

    plan = plan_world(seed, detail)
    PLANNED[(seed, detail)] = plan
    out = {f"world {k}": v for k, v in world_hashes(plan).items()}
    geometry = plan_geometry(plan)
    g = geometry
    out["scan geometry"] = sha(g.vertices, g.faces, g.class_id, g.instance, g.object_index, g.offset)
    # app.poses.plan_backend(plan) would build the same geometry again
    poses = valid_poses(plan, make_backend("auto", geometry=geometry, notify=None), 2, zones)
    out["world.json"] = sha(json.dumps(plan.describe(poses), sort_keys=True).encode())
    with tempfile.TemporaryDirectory() as tmp:
        for zone in zones:
            p = poses[zone][0]
            backend = EmbreeBackend(geometry.cropped((p["x"], p["y"]), 17.0))
            pose = Pose(p["x"], p["y"], p["yaw"])
            for frame, sigma in (("leveled", 0.015), ("world", 0.0)):
                result = run_scan(
                    backend, pose, SensorConfig(rh_deg=rh, noise_sigma=sigma), frame, p.get("z_start")
                )
                ply, side = write_scan_files(
                    Path(tmp) / f"{zone}.ply", result.cloud, dict(result.metadata, seed=seed)
                )
                out[f"{zone} {frame} PLY"] = f"{len(result.cloud)} points " + sha(ply.read_bytes())
                out[f"{zone} {frame} JSON"] = sha(side.read_bytes())
    return out


def drive_hashes(seed: int, detail: str) -> dict[str, str]:
    """Every file of a short drive in the world frame (raw and deskewed PLYs and sidecars,
    TUM trajectory, SemanticKITTI poses and labels, ROS 1 and ROS 2 bags), by name, and the
    float64 poses and points before the files round them (float32 PLYs, 9-digit text)."""
    from wildscan.app.drive import DriveRequest, run_drive
    from wildscan.app.drive import run as drive_run
    from wildscan.core import world as world_module
    from wildscan.core.sensors import SensorConfig

    planner = world_module.plan_world

    def planned(seed_, detail_="default", **options):
        # the default world probe() hashed already is the drive's world; any other is planned
        known = PLANNED.get((seed_, detail_))
        if known is not None and _default_world(options):
            return known
        return planner(seed_, detail_, **options)

    sweeps = []
    original = drive_run.sweep

    def recording(backend, motion, *args, **kwargs):
        sweeps.append((motion, original(backend, motion, *args, **kwargs)))
        return sweeps[-1][1]

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "drive"
        request = DriveRequest(
            out=str(out),
            seed=seed,
            detail=detail,
            trail=True,
            speed=1.0,
            scans=2,
            head="continuous",
            sensor=SensorConfig(rh_deg=10.0, noise_sigma=0.015, noise_seed=3),
            frame="world",
            wind=3.0,
            wind_seed=5,
            bag="both",
        )
        drive_run.sweep = recording
        world_module.plan_world = planned
        try:
            report = run_drive(request, say=lambda text: None)
        finally:
            drive_run.sweep = original
            world_module.plan_world = planner
        files = sorted(f for f in out.rglob("*") if f.is_file())
        hashes = {f"drive {f.relative_to(out)}": sha(f.read_bytes()) for f in files}
    hashes["drive points"] = json.dumps(report.points)
    motion = sweeps[0][0]
    hashes["drive float64 motion"] = sha(motion.centre, motion.ground, motion.rotation, motion.step)
    hashes["drive float64 points"] = sha(*[c.xyz for _, s in sweeps for c in (s.raw, s.deskewed)])
    return hashes


def _default_world(options: dict) -> bool:
    from wildscan.core.world import DEFAULT_BIOME, DEFAULT_VEGETATION

    vegetation = options.get("vegetation", DEFAULT_VEGETATION)
    biome = options.get("biome", DEFAULT_BIOME)
    return not options.get("params") and vegetation == DEFAULT_VEGETATION and biome == DEFAULT_BIOME


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--detail", default="default")
    parser.add_argument("--rh", type=float, default=1.0)
    parser.add_argument("--zones", default="hills,forest,cave")
    parser.add_argument("--drive", action="store_true", help="and a short drive (drive_hashes)")
    a = parser.parse_args()
    hashes = probe(a.seed, a.detail, a.rh, a.zones.split(","))
    if a.drive:
        hashes.update(drive_hashes(a.seed, a.detail))
    print(json.dumps(hashes, indent=1, sort_keys=True))
