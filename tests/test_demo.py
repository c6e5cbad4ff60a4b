"""`wildscan demo` (what `make demo` runs) and `wildscan scan --seed` on the procedural world."""

import json

import numpy as np
import pytest
from matplotlib.image import imread
from plyfile import PlyData

from wildscan.core.classes import CLASSES
from wildscan.core.world import ZONES

from tests.helpers.scene_helpers import WILDSCAN, run

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not


def test_demo_builds_the_world_its_map_and_a_scan_with_preview_per_zone(tmp_path):
    proc = run([WILDSCAN, "demo", "--seed", "1", "--rh", "2", "--out", str(tmp_path / "demo")])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = tmp_path / "demo"
    for name in ("world.blend", "world.json", "map.png"):
        assert (out / name).stat().st_size > 0
    labels = set()
    for zone in ZONES:
        ply = PlyData.read(str(out / f"scan_{zone}.ply"))["vertex"]
        assert ply.count > 10_000
        labels |= set(np.unique(ply["label"]).tolist())
        meta = json.loads((out / f"scan_{zone}.json").read_text())
        assert meta["zone"] == zone and meta["point_count"] == ply.count
        image = imread(str(out / f"scan_{zone}.png"))
        assert image.shape[0] > 400 and len(np.unique(image.reshape(-1, image.shape[-1]), axis=0)) > 5
    assert labels >= {c.id for c in CLASSES}
    assert "all 12 classes across the scans" in proc.stdout


def test_scan_by_seed_builds_the_procedural_world_and_scans_a_listed_pose(tmp_path):
    poses = run([WILDSCAN, "poses", "--seed", "4", "--zone", "park", "--count", "1", "--json"])
    assert poses.returncode == 0, poses.stderr
    p = json.loads(poses.stdout)["poses"]["park"][0]
    out = tmp_path / "park.ply"
    proc = run(
        [
            WILDSCAN,
            "scan",
            "--seed",
            "4",
            "--pose",
            str(p["x"]),
            str(p["y"]),
            str(p["yaw"]),
            "--rh",
            "2",
            "--out",
            str(out),
        ]
    )
    assert proc.returncode == 0, proc.stderr
    labels = set(np.unique(PlyData.read(str(out))["vertex"]["label"]).tolist())
    assert {4, 6, 7} <= labels  # table, fence, bench
