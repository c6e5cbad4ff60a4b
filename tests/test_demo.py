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
    # which world is which: the paper's island first, then the default (endless) world
    first, second = proc.stdout.index("1. the paper's island"), proc.stdout.index("2. the default world")
    assert first < second and "--layout paper --biome paper" in proc.stdout[first:second]
    endless = sorted((out / "endless").glob("scan_*.ply"))
    assert len(endless) >= 3
    for ply in endless:
        meta = json.loads(ply.with_suffix(".json").read_text())
        assert meta["layout"] == "endless" and meta["cover"] == ply.stem[len("scan_") :]
        assert PlyData.read(str(ply))["vertex"].count > 1_000


def test_scan_by_seed_builds_the_procedural_world_and_scans_a_listed_pose(tmp_path):
    poses = run(
        [WILDSCAN, "poses", "--layout", "paper", "--seed", "4", "--zone", "park", "--count", "1", "--json"]
    )
    assert poses.returncode == 0, poses.stderr
    p = json.loads(poses.stdout)["poses"]["park"][0]
    out = tmp_path / "park.ply"
    proc = run(
        [
            WILDSCAN,
            "scan",
            "--layout",
            "paper",
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
