"""Datasets over the endless landscape (SPEC.toml layout = "endless", the default): [poses]
region, cover and tall_cover, the poses they give, the card's land facts, and a 40-scan dataset
of one seed whose poses span the landscape, whose revisits agree with its poses.txt and which
resumes to the bytes of a clean run."""

from __future__ import annotations

import collections
import itertools
import json
import math

import numpy as np
import pytest

from wildscan.app.dataset.spec import spec_from_dict

from tests.helpers.dataset_helpers import (
    assert_same_dataset,
    manifest_rows,
    read_kitti_poses,
    wildscan,
    written_dataset,
)


def test_the_endless_default_spec_and_its_keys_travel_to_the_workers():
    from wildscan.app.dataset.pose_spec import DEFAULT_LAND_MIN_SCANS
    from wildscan.app.dataset.spec import spec_from_json

    spec = spec_from_dict({})
    assert spec.layout == "endless" and spec.poses.land_region() == (-500.0, -500.0, 500.0, 500.0)
    assert dict(spec.poses.cover) == {
        "forest": 2,
        "meadow": 1,
        "scrub": 1,
        "wetland": 1,
        "rock": 1,
        "trail": 1,
        "clearing": 1,
    }
    assert spec.poses.tall_cover == 0.0 and spec.poses.min_scans_with == DEFAULT_LAND_MIN_SCANS
    assert spec_from_dict({"poses": {"min_scans_with": {}}}).poses.min_scans_with == ()  # turned off
    given = spec_from_dict(
        {"poses": {"region": [100, -50, 300, 150], "cover": {"meadow": 1, "rock": 2}, "tall_cover": 0.25}}
    )
    assert given.poses.region == (100.0, -50.0, 300.0, 150.0) and given.poses.tall_cover == 0.25
    assert spec_from_json(given.to_dict()) == given and spec_from_json(spec.to_dict()) == spec
    assert "zones" not in spec.to_dict()["poses"] and given.config_hash() != spec.config_hash()


def test_anchored_classes_stand_where_the_landscape_places_them():
    """Class-aware poses near a table, a pole or a paved path are drawn around the places the
    landscape's anchor cells put them (no tile built): checked against the landscape itself."""
    from wildscan.app.dataset.land import class_anchors
    from wildscan.app.tiles import TiledWorld
    from wildscan.core.world.endless import LAND_COVERS, TRAIL_KINDS, land_cover_at, landscape
    from wildscan.core.world.region import Region

    world, region = TiledWorld(1, "mixed", "default", "porous"), Region(-500, -500, 500, 500)
    anchors = landscape(1, "mixed").anchors
    found = {
        name: np.array(class_anchors(world, region, name)) for name in ("table", "pole", "paved", "soil")
    }
    for name, xy in found.items():
        assert len(xy) > 0, name
        assert ((xy >= -500) & (xy <= 500)).all(), name
    assert anchors.in_clearing(found["table"][:, 0], found["table"][:, 1]).all()
    lines = anchors.lines_over(-500, 500)
    assert all(any(abs(y - line) < 1e-9 for line in lines) and x % 40.0 == 0 for x, y in found["pole"])
    kinds = [k[0] for k in TRAIL_KINDS]
    for name, kind in (("paved", "paved path"), ("soil", "footpath")):
        xy = found[name]
        dist, nearest = anchors.trail_nearest(xy[:, 0], xy[:, 1])
        assert (dist < 1e-6).all(), name
        assert np.mean([kinds[k] == kind for k in nearest]) > 0.9, name  # another kind where two meet
        on = land_cover_at(1, "mixed", xy[:, 0], xy[:, 1])
        assert (on == LAND_COVERS.index("trail")).mean() > 0.9, name


@pytest.mark.slow
def test_cover_weights_set_the_mix_and_tall_cover_its_share(tmp_path):
    """Poses only (placement on the tiles, no scan): the quotas of the weights, each pose on
    its land cover, and tall_cover's share of the poses in tall cover, the others out of it."""
    from wildscan.app.cache.config import cache_config, open_cache
    from wildscan.app.dataset.land import LandBackends, sample_land_poses
    from wildscan.app.tile_memory import TileMemory
    from wildscan.app.tiles import TiledWorld
    from wildscan.core.posesampler import ScanPose
    from wildscan.core.world.endless import LAND_COVERS, land_cover_at

    cache = open_cache(cache_config(tmp_path / "cache"))
    world = TiledWorld(1, "mixed", "low", "porous")
    region = [-150, -150, 150, 150]

    def poses(cover, tall=0.0, count=4):
        spec = spec_from_dict(
            {"poses": {"region": region, "cover": cover, "tall_cover": tall, "min_scans_with": {}}}
        )
        return sample_land_poses(world, spec.poses, count, cache, TileMemory())

    forest = poses({"forest": 3, "meadow": 1})
    meadow = poses({"meadow": 1})
    for got in (forest, meadow):
        assert all(isinstance(p, ScanPose) for p in got)
        xs, ys = np.array([p.x for p in got]), np.array([p.y for p in got])
        assert [LAND_COVERS[c] for c in land_cover_at(1, "mixed", xs, ys)] == [p.zone for p in got]
        assert all(-150 <= p.x <= 150 and -150 <= p.y <= 150 for p in got)
    assert sorted(p.zone for p in forest) == ["forest", "forest", "forest", "meadow"]
    assert [p.zone for p in meadow] == ["meadow"] * 4
    tall = poses({"meadow": 1}, tall=0.5)
    backends = LandBackends(world, cache, TileMemory())
    assert sorted(backends.in_tall_cover(p.x, p.y) for p in tall) == [False, False, True, True]
    assert sum(p.kind == "tall cover" for p in tall) == 2
    assert not any(backends.in_tall_cover(p.x, p.y) for p in meadow)  # tall_cover 0: none


# --------------------------------------------------------------------------- the bar

# The endless default (a seed's 1 km square, the default cover weights and class-aware poses)
# with a small sensor, so that 40 scans take a minute or two from a cold cache. Seed 3: two of
# its scans' pairs stand within 3 m (seeds 0-2 have none), so the revisits hold positives.
LAND_SPEC = """\
seeds = [3]
scans_per_world = 40
formats = ["semantickitti"]
split = { train = 1.0 }

[sensor]
rh = 4.0
max_range = 10.0
"""


@pytest.fixture(scope="module")
def land(tmp_path_factory):
    root = tmp_path_factory.mktemp("land")
    out, _ = written_dataset(root, LAND_SPEC)
    return out


@pytest.mark.slow
def test_a_40_scan_dataset_spans_the_landscape_and_its_revisits_match_its_poses(land):
    poses = read_kitti_poses(land / "sequences/00/poses.txt")
    assert len(poses) == 40
    xy = np.array([p[:2, 3] for p in poses])
    span = max(math.dist(a, b) for a, b in itertools.combinations(xy, 2))
    assert span >= 500.0, span
    revisits = json.loads((land / "revisits.json").read_text())["sequences"]["00"]
    listed = {(a, b): d for a, b, d in revisits["positives"]}
    near = {
        (a, b): math.dist(xy[a], xy[b])
        for a, b in itertools.combinations(range(40), 2)
        if math.dist(xy[a], xy[b]) <= 3.0
    }
    assert set(listed) == set(near) and len(listed) >= 1  # every pair within 3 m, and only those
    for pair, d in listed.items():
        assert d <= 3.0 and d == pytest.approx(near[pair], abs=1e-5)
    rows = manifest_rows(land)
    assert all(r["status"] == "ok" for r in rows)
    covers = collections.Counter(r["zone"] for r in rows)
    assert set(covers) <= {"forest", "meadow", "scrub", "wetland", "rock", "trail", "clearing"}
    assert len(covers) >= 5, covers  # the default's classes stand in clearings, wetland, rock...
    card = json.loads((land / "dataset.json").read_text())["totals"]["land"]
    assert card["area"]["00"]["span_m"] == pytest.approx(span, abs=0.01)
    assert card["cover_scans"] == dict(covers) and 0.0 <= card["near_sensor_share"] < 1.0
    text = (land / "CARD.md").read_text()
    assert "## Land covered" in text and "Points within 0.8 m of the sensor" in text


@pytest.mark.slow
def test_an_endless_dataset_resumed_on_two_workers_is_the_clean_one(land, tmp_path):
    (tmp_path / "spec.toml").write_text(LAND_SPEC)
    out = tmp_path / "out"
    first = wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(out), "--limit", "15", "--quiet")
    assert first.returncode == 0 and len(manifest_rows(out)) == 15, first.stderr
    second = wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(out), "--workers", "2", "--quiet")
    assert second.returncode == 0 and "wrote 25 scans" in second.stdout, second.stderr
    assert_same_dataset(land, out)
    assert (out / "revisits.json").read_bytes() == (land / "revisits.json").read_bytes()


def test_one_worlds_poses_are_placed_once_before_its_workers_and_read_back_by_them(tmp_path):
    """land.poses_before_the_workers: a world that several workers scan gets its poses placed
    once, into the world cache, where each worker's land_poses reads them (the same poses a
    worker places itself); with a world for every worker, or no cache, nothing is done."""
    from wildscan.app.cache.config import cache_config, open_cache
    from wildscan.app.dataset.land import land_poses, poses_before_the_workers
    from wildscan.app.tile_memory import TileMemory

    spec = spec_from_dict(
        {
            "seeds": [1],
            "scans_per_world": 3,
            "detail": "low",
            "poses": {"region": [-100, -100, 100, 100], "cover": {"meadow": 1}, "min_scans_with": {}},
        }
    )
    config = cache_config(tmp_path / "cache")
    said = []
    assert poses_before_the_workers(spec, [1], 1, config) == 0.0  # one worker places its own
    assert poses_before_the_workers(spec, [1], 2, None) == 0.0  # no shared cache to leave them in
    assert poses_before_the_workers(spec, [1], 2, config, said.append) > 0.0
    assert said == ["placing the 3 poses of seed 1 before the workers start (they share them)"]
    read, cached = land_poses(spec, 1, open_cache(config), TileMemory())
    fresh, fresh_cached = land_poses(spec, 1, None, TileMemory())
    assert cached and not fresh_cached and read == fresh and len(read) == 3
