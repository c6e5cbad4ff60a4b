"""The golden guards: world content hashes and scan checksums that a refactor must not move.

`tests/golden/worlds.json` holds the content hash (`plan_hash`, the `hash` of world.json)
of seeds 0-3 at every detail level, with porous vegetation (the default, "seed/detail") and
solid ("seed/detail/solid", the worlds from before porous vegetation existed), all of them
in the `paper` biome (the world from before biomes: no ground cover, no deadwood; the default
biome `mixed` covers the ground, so `--biome paper` is what reproduces these files);
`tests/golden/scans.json` the SHA-256 of PLY files scanned through the Blender path (the
first valid pose of each zone of seed 1 with porous and with solid vegetation, the forest's
also with the realistic sensor model, and the test world with every ray backend). Each
scan stores two checksums: of the whole file, and of its vertex records alone, so a
deliberate header change (which moves the first) still proves the points themselves did
not move.

Only a deliberate behaviour change may rewrite them, in a commit of its own that says why:

    .venv/bin/python tests/helpers/golden_cases.py --write
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

GOLDEN = Path(__file__).parents[1] / "golden"
WORLD_SEEDS = (0, 1, 2, 3)
DETAILS = ("low", "default", "high")
VEGETATION = ("porous", "solid")  # porous is the default: its keys carry no suffix
SCAN_SEED = 1
TEST_WORLD_SEED = 7
TEST_WORLD_POSE = (0.0, 0.0, 20.0)
TEST_WORLD_RH = 2.0  # scene.ray_cast takes ~0.5 s for this scan
BACKENDS = ("blender", "bvh", "embree")
BIOME = "paper"  # what the golden files pin (core/world/biomes.py)


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def suffix(vegetation: str) -> str:
    return "" if vegetation == "porous" else f"/{vegetation}"


def world_hashes() -> dict[str, str]:
    from wildscan.core.world import plan_hash, plan_world

    return {
        f"{seed}/{detail}{suffix(veg)}": plan_hash(plan_world(seed, detail, vegetation=veg, biome=BIOME))
        for veg in VEGETATION
        for seed in WORLD_SEEDS
        for detail in DETAILS
    }


def scan_checksums(result, seed, directory: Path, name: str) -> dict:
    """Write a scan as `wildscan scan` does and return its pose and checksums."""
    from wildscan.core.io.ply import read_ply, write_scan_files

    ply, _ = write_scan_files(directory / f"{name}.ply", result.cloud, dict(result.metadata, seed=seed))
    records, _ = read_ply(ply)
    return {
        "points": len(result.cloud),
        "ply_sha256": sha256(ply.read_bytes()),
        "points_sha256": sha256(records.tobytes()),
    }


def zone_scans(directory: Path, vegetation: str) -> dict[str, dict]:
    """Seed 1 built in Blender, the first valid pose of each zone scanned with embree (the
    forest's also with the realistic sensor model, with porous vegetation)."""
    from wildscan.app.poses import plan_backend, valid_poses
    from wildscan.app.scan import scan_current_scene
    from wildscan.blender.builder import build_world
    from wildscan.blender.scene_io import empty_scene
    from wildscan.core.placement import Pose
    from wildscan.core.sensors import SensorConfig
    from wildscan.raycast.extract import extract_scene

    empty_scene()
    plan = build_world(SCAN_SEED, vegetation=vegetation, biome=BIOME)
    poses = valid_poses(plan, plan_backend(plan), 1)
    geometry = extract_scene()
    sensors = {"": SensorConfig()}
    out = {}
    for zone, (p,) in poses.items():
        pose = Pose(p["x"], p["y"], p["yaw"])
        if zone == "forest" and vegetation == "porous":
            sensors["/realistic"] = SensorConfig(model="realistic")
        for model, sensor in sensors.items():
            result = scan_current_scene(
                pose, sensor, "leveled", p.get("z_start"), "embree", geometry=geometry
            )
            entry = {"pose": [p["x"], p["y"], p["yaw"], p.get("z_start")]}
            name = f"seed{SCAN_SEED}_{zone}_{vegetation}{model.replace('/', '_')}"
            entry.update(scan_checksums(result, SCAN_SEED, directory, name))
            out[f"seed{SCAN_SEED}/{zone}{suffix(vegetation)}{model}"] = entry
        sensors.pop("/realistic", None)
    return out


def test_world_scans(directory: Path) -> dict[str, dict]:
    """The test world scanned from one pose by every backend (noise on, as a user scans)."""
    from wildscan.app.scan import scan_current_scene
    from wildscan.blender.scene_io import empty_scene
    from wildscan.blender.testworld import build_test_world
    from wildscan.core.placement import Pose
    from wildscan.core.sensors import SensorConfig

    empty_scene()
    build_test_world(TEST_WORLD_SEED)
    out = {}
    for backend in BACKENDS:
        result = scan_current_scene(
            Pose(*TEST_WORLD_POSE), SensorConfig(rh_deg=TEST_WORLD_RH), backend=backend
        )
        entry = {"pose": list(TEST_WORLD_POSE), "rh": TEST_WORLD_RH}
        entry.update(scan_checksums(result, None, directory, f"testworld_{backend}"))
        out[f"testworld/{backend}"] = entry
    return out


test_world_scans.__test__ = False  # a helper, not a pytest test


def all_scans() -> dict[str, dict]:
    with tempfile.TemporaryDirectory() as tmp:
        scans = {k: v for veg in VEGETATION for k, v in zone_scans(Path(tmp), veg).items()}
        return {**scans, **test_world_scans(Path(tmp))}


def load(name: str) -> dict:
    return json.loads((GOLDEN / name).read_text())


def write(name: str, values: dict) -> None:
    GOLDEN.mkdir(exist_ok=True)
    (GOLDEN / name).write_text(json.dumps(values, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/helpers/golden_cases.py --write   (rewrites tests/golden/*.json)")
    write("worlds.json", world_hashes())
    write("scans.json", all_scans())
    print(f"wrote {GOLDEN}/worlds.json and scans.json")
