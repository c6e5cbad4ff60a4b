"""`wildscan dataset`: the spec contract, seeded poses and sensor draws, splits, and every
format read back by the readers users have (an independent SemanticKITTI reader written
from the published layout, PyYAML for the label config, laspy and the LASzip reference
library for LAS, plyfile, PCL and CloudCompare for PLY). A missing tool is a failure.

One small dataset (2 worlds x 3 scans at r_h = 4 deg, every format) is made once per
module with the real command on a local Dask cluster of 2 workers.
"""

from __future__ import annotations

import hashlib
import json
import subprocess

import numpy as np
import plyfile
import pytest
import yaml

from wildscan.app.dataset.draws import draw_sensor
from wildscan.app.dataset.spec import spec_from_dict
from wildscan.core.classes import BY_ID, LOG_ID
from wildscan.core.errors import UserError
from wildscan.core.io.las import ASPRS_CODES
from wildscan.core.label_schemes import SCHEMES
from wildscan.core.placement import COLUMN_HEIGHT

from tests.helpers.dataset_helpers import (
    SMALL_SPEC,
    manifest_rows,
    read_kitti_calib,
    read_kitti_labels,
    read_kitti_poses,
    read_kitti_scan,
    wildscan,
    written_dataset,
)
from tests.helpers.reader_helpers import (
    cloudcompare_env,
    parse_ascii_pcd,
    parse_cloudcompare_asc,
    require_tool,
)

# --------------------------------------------------------------------------- the spec


def test_a_spec_names_its_layout_endless_by_default_and_paper_keeps_its_config_hash():
    assert spec_from_dict({}).layout == "endless" and spec_from_dict({"layout": "endless"}) == spec_from_dict(
        {}
    )
    paper = spec_from_dict({"layout": "paper"})
    assert (
        paper.layout == "paper" and "layout" not in paper.to_dict()
    )  # a paper spec's dict as before layouts
    assert set(paper.to_dict()["poses"]) == {"strategy", "zones", "min_distance"}


def test_an_empty_spec_takes_every_documented_default():
    spec = spec_from_dict({"layout": "paper"})
    assert spec.seeds == (0, 1, 2)
    assert spec.detail == "default" and spec.scans_per_world == 50
    assert spec.formats == ("semantickitti", "las", "ply") and spec.label_scheme == "wildscan"
    assert dict(spec.split) == {"train": 0.8, "val": 0.1, "test": 0.1}
    assert spec.poses.strategy == "zones" and spec.poses.min_distance == 2.0
    assert dict(spec.poses.zones) == {"hills": 1, "forest": 2, "park": 1, "lake": 1, "cave": 1, "trail": 1}
    assert (spec.sensor.rh, spec.sensor.max_range, spec.sensor.model) == (1.0, 15.0, "paper")
    assert spec.sensor.noise is None  # the model's own: 0.015 m with the paper model
    assert spec.intensity == "physical"  # a dataset's default (a single scan keeps the class tag)


@pytest.mark.parametrize(
    "data, words",
    [
        ({"seed": [1]}, ["unknown key 'seed'", "seeds"]),
        ({"sensor": {"nosie": 0.01}}, ["unknown key 'sensor.nosie'", "noise"]),
        ({"layout": "paper", "poses": {"zones": {"desert": 1}}}, ["poses.zones.desert", "hills"]),
        ({"seeds": "5..2"}, ["seeds must be", '"A..B"']),
        ({"seeds": [1, 1]}, ["without repeats"]),
        ({"seeds": "0..30000000"}, ["seeds must be", "30,000,001 worlds"]),  # sized, not expanded
        ({"seeds": "²..³"}, ["seeds must be", '"²..³"']),  # digits int() refuses
        ({"seeds": "1..٣"}, ["seeds must be", '"1..٣"']),
        ({"detail": "ultra"}, ["detail must be one of", '"low"']),
        ({"formats": ["kitti"]}, ["formats must be", '"semantickitti"']),
        ({"label_scheme": "nuscenes"}, ["label_scheme", '"rellis3d"']),
        ({"split": {"train": 0.5}}, ["add up to 1"]),
        ({"sensor": {"noise": 2.0}}, ["sensor.noise must be", "0 to 1 m"]),
        ({"sensor": {"noise": [0.03, 0.01]}}, ["sensor.noise", "lo <= hi"]),
        ({"sensor": {"rh": 7.0}}, ["sensor.rh", "divides 180"]),
        ({"sensor": {"min_range": [0.1, 20.0], "max_range": 15.0}}, ["min_range must stay below"]),
        ({"scans_per_world": 0}, ["scans_per_world must be a whole number"]),
        ({"scans_per_world": True}, ["scans_per_world"]),
        ({"layout": "paper", "poses": {"strategy": "grid"}}, ["poses.strategy", '"uniform"']),
        ({"intensity": "tag"}, ["intensity must be one of", '"physical"', '"class"']),
        ({"vegetation": "leafy"}, ["vegetation must be one of", '"porous"', '"solid"']),
        ({"sensor": {"model": "lidar"}}, ["sensor.model must be one of", '"realistic"']),
        ({"sensor": {"divergence": 3.0}}, ["sensor.divergence applies to model", '"realistic" only']),
        ({"sensor": {"echoes": 2}}, ["sensor.echoes applies to model"]),
        ({"sensor": {"model": "realistic", "echoes": 4}}, ["sensor.echoes must be a whole number", "1 to 3"]),
        ({"sensor": {"model": "realistic", "echoes": [3, 1]}}, ["sensor.echoes", "range"]),
        ({"sensor": {"model": "realistic", "echoes": 2.5}}, ["sensor.echoes must be a whole number"]),
        ({"sensor": {"model": "realistic", "divergence": 80}}, ["sensor.divergence must be", "0 to 50 mrad"]),
        ({"sensor": {"model": "realistic", "echo_separation": 0}}, ["sensor.echo_separation", "above 0"]),
        ({"sensor": {"model": "realistic", "echo-separation": 1}}, ["unknown key", "echo_separation"]),
        ({"layout": "island"}, ["layout must be one of", "'endless'", "'paper'"]),
        # [poses] of the endless layout (tests/test_dataset_land.py)
        ({"biome": "paper"}, ['biome = "paper"', 'layout = "paper"', "endless landscape"]),
        (
            {"poses": {"zones": {"forest": 1}}},
            ['poses.zones applies to layout = "paper"', "poses.cover"],
        ),
        ({"poses": {"strategy": "uniform"}}, ['poses.strategy applies to layout = "paper" only']),
        (
            {"layout": "paper", "poses": {"region": [0, 0, 50, 50]}},
            ['poses.region applies to layout = "endless"'],
        ),
        (
            {"layout": "paper", "poses": {"cover": {"forest": 1}}},
            ['poses.cover applies to layout = "endl'],
        ),
        (
            {"layout": "paper", "poses": {"tall_cover": 0.1}},
            ["poses.tall_cover applies to layout"],
        ),
        (
            {"poses": {"region": [0, 0, 50]}},
            ["poses.region must be four", "XMIN < XMAX", "[0, 0, 50]"],
        ),
        ({"poses": {"region": [10, 0, 0, 50]}}, ["poses.region must be", "got [10, 0, 0, 50]"]),
        ({"poses": {"region": [0, 0, 5, 50]}}, ["poses.region must be", "at least 10 m"]),
        ({"poses": {"region": [0, 0, 9000, 50]}}, ["poses.region must be", "8900 m"]),
        ({"poses": {"region": [0, 0, "a", 50]}}, ["poses.region must be four numbers"]),
        ({"poses": {"region": "everywhere"}}, ["poses.region must be four numbers"]),
        ({"poses": {"cover": {"lake": 1}}}, ["unknown key 'poses.cover.lake'", "wetland", "clearing"]),
        (
            {"poses": {"cover": {"forest": 0}}},
            ["poses.cover must give at least one land cover"],
        ),
        ({"poses": {"cover": {"forest": -1}}}, ["poses.cover.forest must be a number from 0"]),
        ({"poses": {"tall_cover": 1.5}}, ["poses.tall_cover must be a number from 0 to 1", "1.5"]),
        ({"poses": {"tall_cover": "some"}}, ["poses.tall_cover must be a number"]),
    ],
)
def test_a_bad_key_or_value_names_the_key_and_what_is_allowed(data, words):
    with pytest.raises(UserError) as e:
        spec_from_dict(data)
    message = str(e.value)
    assert "\n" not in message
    for word in words:
        assert word in message


@pytest.mark.slow
@pytest.mark.parametrize(
    "text, key",
    [
        ("scans_per_worlds = 3\n", "scans_per_worlds"),
        ('[sensor]\nmodel = "realistic"\nechoes = 5\n', "sensor.echoes"),
    ],
)
def test_the_command_exits_2_with_one_line_and_writes_nothing(tmp_path, text, key):
    spec = tmp_path / "spec.toml"
    spec.write_text(text)
    result = wildscan("dataset", str(spec), "--out", str(tmp_path / "out"))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and key in result.stderr
    assert not (tmp_path / "out").exists()
    spec.write_text("seeds = [1\n")
    result = wildscan("dataset", str(spec), "--out", str(tmp_path / "out"))
    assert result.returncode == 2 and "not valid TOML" in result.stderr


def test_seed_ranges_and_sensor_ranges_draw_per_scan_reproducibly():
    spec = spec_from_dict(
        {"seeds": "3..6", "sensor": {"rh": [0.5, 2.0], "noise": [0.01, 0.03], "noise_seed": 9}}
    )
    assert spec.seeds == (3, 4, 5, 6)
    draws = [draw_sensor(spec.sensor, 4, k) for k in range(20)]
    assert draws == [draw_sensor(spec.sensor, 4, k) for k in range(20)]
    assert len({d.noise_sigma for d in draws}) == 20 and all(0.01 <= d.noise_sigma <= 0.03 for d in draws)
    assert all(0.5 <= d.rh_deg <= 2.0 and (180 / d.rh_deg) == round(180 / d.rh_deg) for d in draws)
    assert len({d.rh_deg for d in draws}) > 5 and {d.noise_seed for d in draws} == {9}
    unseeded = spec_from_dict({})
    seeds = {draw_sensor(unseeded.sensor, 4, k).noise_seed for k in range(20)}
    assert len(seeds) == 20  # every scan its own noise unless the spec fixes it


def test_a_huge_seed_range_is_refused_in_one_line_before_it_is_expanded(tmp_path):
    import resource

    def four_gigabytes():  # expanding 2^31 seeds would take 17 GB: a MemoryError here
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))

    spec = tmp_path / "spec.toml"
    spec.write_text('seeds = "0..2147483647"\n')
    result = wildscan("dataset", str(spec), "--out", str(tmp_path / "out"), preexec_fn=four_gigabytes)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "seeds must be" in result.stderr and "2,147,483,648 worlds" in result.stderr
    assert not (tmp_path / "out").exists()


def test_a_split_with_a_share_but_no_world_is_named_in_a_warning():
    warning = spec_from_dict({}).empty_split_warning()  # three seeds at 0.8 / 0.1 / 0.1
    assert "val (share 0.1) and test (share 0.1) get no world" in warning and "\n" not in warning
    assert "3 seeds give train 3, val 0, test 0" in warning
    assert spec_from_dict({"seeds": "0..19"}).empty_split_warning() is None
    assert spec_from_dict({"seeds": [4], "split": {"train": 1.0}}).empty_split_warning() is None


def test_splits_are_by_world_and_follow_the_shares():
    spec = spec_from_dict({"seeds": "0..19"})
    splits = spec.splits()
    assert sorted(splits) == list(range(20))
    assert [list(splits.values()).count(s) for s in ("train", "val", "test")] == [16, 2, 2]
    assert spec_from_dict({"seeds": "0..19", "scans_per_world": 7}).splits() == splits


def test_the_config_hash_changes_with_any_key():
    base = spec_from_dict({})
    assert base.config_hash() == spec_from_dict({"detail": "default"}).config_hash()
    for change in (
        {"detail": "low"},
        {"sensor": {"noise": 0.02}},
        {"formats": ["las"]},
        {"poses": {"min_distance": 3}},
        {"intensity": "class"},
    ):
        assert spec_from_dict(change).config_hash() != base.config_hash()


# --------------------------------------------------------------------------- the small dataset


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("dataset")
    spec = root / "spec.toml"
    spec.write_text(SMALL_SPEC)
    result = wildscan("dataset", str(spec), "--out", str(root / "out"), "--workers", "2")
    assert result.returncode == 0, result.stderr
    assert "complete: 6 of 6 scans" in result.stdout
    return root / "out"


def ok_rows(root):
    return [r for r in manifest_rows(root) if r["status"] == "ok"]


@pytest.mark.slow
def test_the_manifest_has_a_complete_row_per_scan(dataset):
    rows = manifest_rows(dataset)
    assert [(r["sequence"], r["scan"]) for r in rows] == [(s, k) for s in ("00", "01") for k in range(3)]
    keys = {
        "seed",
        "scan",
        "split",
        "pose",
        "sensor",
        "config_hash",
        "wildscan_version",
        "files",
        "seconds",
        "zone",
    }
    for row in rows:
        assert row["status"] == "ok" and keys <= set(row)
        assert set(row["sensor"]) == {"rh", "min_range", "max_range", "noise", "noise_seed", "frame"}
        assert 0.01 <= row["sensor"]["noise"] <= 0.02  # drawn from the spec's range and recorded
        for f in row["files"]:
            assert (dataset / f["path"]).stat().st_size == f["bytes"] and len(f["sha256"]) == 64
    assert {r["zone"] for r in rows} == {"forest", "park", "hills"}


@pytest.mark.slow
def test_splits_never_share_a_world(dataset):
    rows = manifest_rows(dataset)
    split_of = {}
    for r in rows:
        assert split_of.setdefault(r["seed"], r["split"]) == r["split"]
    card = json.loads((dataset / "dataset.json").read_text())
    assert {s["seed"]: s["split"] for s in card["sequences"]} == split_of
    config = yaml.safe_load((dataset / "labels.yaml").read_text())
    train, valid, test = (set(config["split"][k]) for k in ("train", "valid", "test"))
    assert not (train & valid or train & test or valid & test)
    assert train | valid | test == {0, 1}


@pytest.mark.slow
def test_the_label_config_loads_in_semantic_kitti_api_form(dataset):
    config = yaml.safe_load((dataset / "labels.yaml").read_text())
    for key in (
        "labels",
        "color_map",
        "learning_map",
        "learning_map_inv",
        "learning_ignore",
        "split",
        "content",
    ):
        assert key in config, key
    assert config["labels"][72] == "terrain" and config["labels"][99] == "other-object"
    assert set(config["learning_map"]) == set(config["labels"]) == set(config["color_map"])
    assert all(v in config["learning_map_inv"] for v in config["learning_map"].values())
    assert abs(sum(config["content"].values()) - 1.0) < 1e-9
    assert all(len(c) == 3 for c in config["color_map"].values())


# sha256 of each scheme's label config for a clear dataset, as the code before the particle class
# wrote it (content {2: 0.5}, train [0], valid [1]): a clear dataset keeps every byte. WildScan's
# own config lists class 14 log since deadwood came (the other schemes already had an id for it).
CLEAR_LABEL_CONFIGS = {
    "wildscan": "7b43efdfec33478759a653306e509f21f5dbf117c636878370cbcbdac1d2dbe4",
    "semantickitti": "26827f6a89e8135a7ac4e2bc91f29244b77e8afb8eba50bf49dbbe935dcc7331",
    "rellis3d": "6a5d9b0b9813add47752afa945e939b740f3c7e2638927aca284e5356c59c974",
    "goose": "994b29fad5092bdf8fc08218abb7a887d5812fe713aea7331a6c637a3032fd93",
}


@pytest.mark.parametrize("name", sorted(CLEAR_LABEL_CONFIGS))
def test_a_clear_label_config_keeps_the_bytes_of_before_the_particle_class(name):
    import hashlib

    from wildscan.core.classes import PARTICLE_ID, listed_classes
    from wildscan.core.io.semantickitti import label_config_yaml

    args = (SCHEMES[name], {2: 0.5}, {"train": [0], "valid": [1]}, "WildScan dataset")
    clear = label_config_yaml(*args).encode()
    assert hashlib.sha256(clear).hexdigest() == CLEAR_LABEL_CONFIGS[name]
    weather = yaml.safe_load(label_config_yaml(*args, listed_classes(declared=(PARTICLE_ID,))))
    particle = SCHEMES[name].from_wildscan[15]
    assert particle in weather["labels"] and particle in weather["color_map"]


@pytest.mark.slow
def test_class_weights_in_labels_yaml_and_weights_json_come_from_the_points_written(dataset):
    config = yaml.safe_load((dataset / "labels.yaml").read_text())
    weights = json.loads((dataset / "weights.json").read_text())
    assert weights["label_scheme"] == "semantickitti"
    scheme = SCHEMES["semantickitti"]
    written: dict[int, int] = {}
    for row in ok_rows(dataset):
        for cid, n in row["class_counts"].items():
            xid = scheme.learning_map[scheme.from_wildscan[int(cid)]]
            if not scheme.learning_ignore[xid]:
                written[xid] = written.get(xid, 0) + n
    total = sum(written.values())
    for xid, entry in weights["classes"].items():
        xid = int(xid)
        assert entry["points"] == written.get(xid, 0)
        if entry["points"]:
            assert entry["enet"] == pytest.approx(1 / np.log(1.02 + entry["points"] / total))
            assert config["class_weights_enet"][xid] == pytest.approx(entry["enet"], rel=1e-5)
            assert config["class_weights_inverse_frequency"][xid] == pytest.approx(
                entry["inverse_frequency"], rel=1e-5
            )
        else:
            assert config["class_weights_enet"][xid] == 0.0
    listed = json.loads((dataset / "dataset.json").read_text())["files"]
    assert "weights.json" in listed  # --verify checks it like every other file


@pytest.mark.slow
def test_a_clear_datasets_label_config_does_not_list_the_particle_class(dataset):
    assert "particle" not in (dataset / "labels.yaml").read_text()


@pytest.mark.slow
def test_an_independent_semantickitti_reader_loads_every_scan(dataset):
    scheme = SCHEMES["semantickitti"]
    config = yaml.safe_load((dataset / "labels.yaml").read_text())
    for seq in ("00", "01"):
        folder = dataset / "sequences" / seq
        scans = sorted((folder / "velodyne").glob("*.bin"))
        poses = read_kitti_poses(folder / "poses.txt")
        calib = read_kitti_calib(folder / "calib.txt")
        assert len(scans) == len(poses) == 3 and np.array_equal(calib["Tr"], np.eye(4))
        for scan, pose in zip(scans, poses, strict=True):
            xyz, remission = read_kitti_scan(scan)
            sem, inst = read_kitti_labels(folder / "labels" / f"{scan.stem}.label")
            hag = np.fromfile(folder / "hag" / scan.name, dtype=np.float32)
            ply = plyfile.PlyData.read(str(folder / "ply" / f"{scan.stem}.ply"))["vertex"]
            assert len(xyz) == len(sem) == len(hag) == ply.count > 1000
            np.testing.assert_array_equal(sem, scheme.map(ply["label"]))
            assert set(np.unique(sem)) <= set(config["labels"])
            assert inst.max() > 0 and np.all(inst[ply["label"] == 0] == 0)
            np.testing.assert_allclose(remission, ply["intensity"] / 100, rtol=1e-6)
            assert remission.min() >= 0.0 and remission.max() <= 1.0
            np.testing.assert_array_equal(xyz[:, 0], ply["x"])
            # poses.txt takes the points to the world: the terrain under them is hag below
            sidecar = json.loads((folder / "ply" / f"{scan.stem}.json").read_text())
            assert sidecar["intensity"] == "physical"  # what the intensity of these files means
            centre = np.array(sidecar["placement"]["optical_centre"])
            np.testing.assert_allclose(pose[:3, 3], centre, atol=1e-9)
            world = xyz.astype(np.float64) @ pose[:3, :3].T + pose[:3, 3]
            assert np.allclose(world[:, 2] - hag, world[:, 2] - ply["hag"], atol=1e-4)


# One world whose cave zone runs out of room at scan 4 while the hills go on: scans 0-3 and 5
# have a pose, scan 4 has none (tests/test_dataset.py found this layout with seed 1).
GAP_SPEC = """\
layout = "paper"
seeds = [1]
detail = "low"
vegetation = "solid"
scans_per_world = 6
formats = ["semantickitti"]

[poses]
zones = { cave = 1, hills = 1 }
min_distance = 40.0

[sensor]
rh = 10.0
"""


@pytest.fixture(scope="module")
def gap_dataset(tmp_path_factory):
    return written_dataset(tmp_path_factory.mktemp("gap"), GAP_SPEC)


@pytest.mark.slow
def test_a_sequence_with_a_failed_scan_reads_back_as_semantic_kitti_api_reads_it(gap_dataset):
    from wildscan.core.truth.groundtruth import height_above_ground
    from wildscan.core.world import plan_world

    out, result = gap_dataset
    assert [r["status"] for r in manifest_rows(out)] == ["ok"] * 4 + ["failed", "ok"]
    folder = out / "sequences" / "00"
    # semantic-kitti-api: the sorted file names, and poses.txt by line index
    scans = sorted((folder / "velodyne").glob("*.bin"))
    poses = read_kitti_poses(folder / "poses.txt")
    assert [p.name for p in scans] == [f"{k:06d}.bin" for k in range(5)]  # dense: no gap at 4
    assert len(poses) == 5
    assert sorted(p.name for p in (folder / "labels").iterdir()) == [f"{k:06d}.label" for k in range(5)]
    # line k is the pose of file k: its points land where their recorded height above the
    # world's terrain says (a neighbour's pose puts them metres off)
    ground = plan_world(1, "low", vegetation="solid").standing_ground()
    for scan, pose in zip(scans, poses, strict=True):
        xyz, _ = read_kitti_scan(scan)
        world = xyz.astype(np.float64) @ pose[:3, :3].T + pose[:3, 3]
        hag = np.fromfile(folder / "hag" / scan.name, dtype=np.float32)
        np.testing.assert_allclose(height_above_ground(world, ground), hag, atol=1e-3, err_msg=scan.name)
    last = manifest_rows(out)[5]
    assert {f["path"] for f in last["files"]} >= {"sequences/00/velodyne/000004.bin"}


@pytest.mark.slow
def test_revisits_json_pairs_what_poses_txt_puts_within_3_m_and_verify_knows_it(gap_dataset):
    """revisits.json at finalize: the pairs poses.txt puts within 3 m (none here: the poses
    keep 40 m apart), each scan's count beyond 25 m, file numbers mapped to manifest scans
    past the scan without a pose; listed in dataset.json with its checksum, so --verify checks it."""
    out, _ = gap_dataset
    doc = json.loads((out / "revisits.json").read_text())
    seq = doc["sequences"]["00"]
    poses = read_kitti_poses(out / "sequences" / "00" / "poses.txt")
    xy = np.array([pose[:2, 3] for pose in poses])
    distance = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    assert seq["manifest_scan"] == [0, 1, 2, 3, 5] and seq["scans"] == len(poses) == 5
    assert {(a, b) for a, b, _ in seq["positives"]} == {
        (a, b) for a, b in zip(*np.nonzero(distance <= 3)) if a < b
    }
    assert (
        seq["negatives_per_scan"] == (distance > 25).sum(axis=1).tolist()
        and sum(seq["negatives_per_scan"]) > 0
    )
    assert (
        doc["positive_radius_m"] == 3.0
        and doc["negative_radius_m"] == 25.0
        and "Wild-Places" in doc["source"]
    )
    listed = json.loads((out / "dataset.json").read_text())["files"]["revisits.json"]
    data = (out / "revisits.json").read_bytes()
    assert listed["bytes"] == len(data) and listed["sha256"] == hashlib.sha256(data).hexdigest()


@pytest.mark.slow
def test_the_run_says_what_it_wrote_and_warns_of_empty_splits(gap_dataset):
    _, result = gap_dataset
    assert "wrote 5 scans in " in result.stdout and "1 more recorded without a valid pose" in result.stdout
    assert "complete: 5 of 6 scans, 1 without a valid pose" in result.stdout
    # one world at the default 0.8 / 0.1 / 0.1: val and test get none, and the run says so
    warnings = [line for line in result.stderr.splitlines() if "warning" in line]
    assert warnings == [
        "wildscan dataset: warning: splits val (share 0.1) and test (share 0.1) get no world: 1 seed "
        "gives train 1, val 0, test 0; give more seeds or set their shares to 0"
    ]


@pytest.mark.slow
def test_hag_is_small_on_the_terrain_and_large_on_tree_crowns(dataset):
    ply = plyfile.PlyData.read(str(dataset / "sequences/00/ply/000000.ply"))["vertex"]
    terrain = ply["label"] == 1
    assert np.median(np.abs(ply["hag"][terrain])) < 0.03  # range noise of 1-2 cm, trail flooring 3 cm
    crowns = ply["label"] == 3
    if crowns.any():
        assert np.median(ply["hag"][crowns]) > 1.5


@pytest.mark.slow
def test_the_birds_eye_grid_is_300_cells_of_terrain_height_and_top_class(dataset):
    grid = np.load(dataset / "sequences/00/bev/000000.npy")
    assert grid.shape == (300, 300) and grid.dtype.names[:2] == ("terrain_z", "top_class")
    centre = grid["terrain_z"][149:151, 149:151]
    assert np.all(np.abs(centre + COLUMN_HEIGHT) < 0.15)  # the optical centre stands 0.723 m up
    assert set(np.unique(grid["top_class"])) <= set(SCHEMES["semantickitti"].labels)
    assert (grid["top_class"] == 72).mean() > 0.2  # terrain seen from above somewhere


@pytest.mark.slow
def test_laspy_reads_las_1_4_with_asprs_codes_and_extra_dimensions(dataset):
    import laspy

    las = laspy.read(dataset / "sequences/01/las/000001.las")
    ply = plyfile.PlyData.read(str(dataset / "sequences/01/ply/000001.ply"))["vertex"]
    assert str(las.header.version) == "1.4" and las.header.point_format.id == 7
    assert list(las.point_format.extra_dimension_names) == [
        "wildscan_label", "label", "instance", "ring", "sweep", "range", "hag",
    ]  # fmt: skip
    np.testing.assert_array_equal(las.wildscan_label, ply["label"])
    np.testing.assert_array_equal(las.classification, [ASPRS_CODES[int(c)] for c in ply["label"]])
    np.testing.assert_array_equal(las.label, SCHEMES["semantickitti"].map(ply["label"]))
    np.testing.assert_array_equal(las.instance, ply["instance"])
    np.testing.assert_allclose(las.x, ply["x"], atol=1e-4)
    np.testing.assert_allclose(las.hag, ply["hag"])
    assert las.header.creation_date.year == 2000  # fixed: same scan, same bytes


@pytest.mark.slow
def test_the_laszip_reference_library_reads_the_las_files(dataset):
    import laspy
    import laszip

    path = dataset / "sequences/00/las/000002.las"
    expected = laspy.read(path)
    reader = laszip.LasZipDll()
    reader.open_reader(str(path))
    header = reader.header()
    assert (header.version_major, header.version_minor, header.point_data_format) == (1, 4, 7)
    assert header.extended_number_of_point_records == len(expected.x)
    for k in range(200):
        reader.read_point()
        point = reader.point()
        assert point.X == expected.X[k] and point.extended_classification == expected.classification[k]
        assert int.from_bytes(bytes(point.extra_bytes)[:2], "little") == expected.wildscan_label[k]
    reader.close_reader()


@pytest.mark.slow
def test_plyfile_reads_the_ply_with_hag_after_the_contract_fields(dataset):
    vertex = plyfile.PlyData.read(str(dataset / "sequences/00/ply/000001.ply"))["vertex"]
    names = [p.name for p in vertex.properties]
    assert names[-3:] == ["scalar_label", "hag", "support"] and names[:5] == [
        "x",
        "y",
        "z",
        "intensity",
        "label",
    ]
    hag = np.fromfile(dataset / "sequences/00/hag/000001.bin", dtype=np.float32)
    np.testing.assert_array_equal(vertex["hag"], hag)
    # support follows from the label and hag (core/truth/traversability.py), which the other formats carry
    np.testing.assert_array_equal(vertex["support"], (vertex["label"] == 1) & (np.abs(hag) <= 0.1))


@pytest.mark.slow
def test_pcl_reads_the_ply_labels_and_hag(dataset, tmp_path):
    exe = require_tool("pcl_ply2pcd", "pcl-tools")
    ply = dataset / "sequences/01/ply/000000.ply"
    subprocess.run(
        [exe, "-format", "0", str(ply), str(tmp_path / "s.pcd")], check=True, capture_output=True, timeout=300
    )
    header, columns = parse_ascii_pcd(tmp_path / "s.pcd")
    vertex = plyfile.PlyData.read(str(ply))["vertex"]
    assert "label" in header["FIELDS"] and "hag" in header["FIELDS"]
    np.testing.assert_array_equal(columns["label"], vertex["label"])
    np.testing.assert_allclose(columns["hag"], vertex["hag"], rtol=1e-6, atol=1e-6)


@pytest.mark.slow
def test_cloudcompare_loads_every_ply_of_the_dataset_with_its_classes(dataset, tmp_path):
    exe = require_tool("CloudCompare", "cloudcompare")
    env = cloudcompare_env(tmp_path)
    for ply in sorted(dataset.glob("sequences/*/ply/*.ply")):
        out = tmp_path / f"{ply.parent.parent.name}_{ply.stem}.asc"
        subprocess.run(
            [exe, "-SILENT", "-O", str(ply), "-C_EXPORT_FMT", "ASC", "-ADD_HEADER", "-SEP", "SPACE",
             "-NO_TIMESTAMP", "-SAVE_CLOUDS", "FILE", str(out)],
            check=True, capture_output=True, timeout=120, env=env, cwd=tmp_path,
        )  # fmt: skip
        columns = parse_cloudcompare_asc(out)
        vertex = plyfile.PlyData.read(str(ply))["vertex"]
        np.testing.assert_array_equal(columns["label"], vertex["label"])


@pytest.mark.slow
def test_the_card_compares_with_rellis_and_counts_classes(dataset):
    card = (dataset / "CARD.md").read_text()
    for words in ("RELLIS-3D", "| grass |", "Points against range", "Scans per zone and split", "scans/s"):
        assert words in card
    assert "Intensity: physical" in card and "Remission alone labels" in card and "Warning" not in card
    for png in ("classes.png", "range.png", "zones.png"):
        assert (dataset / "card" / png).stat().st_size > 1000
    data = json.loads((dataset / "dataset.json").read_text())
    totals = data["totals"]
    assert totals["scans_ok"] == 6 and totals["points"] == sum(r["points"] for r in ok_rows(dataset))
    assert set(totals["class_points"]) == {BY_ID[i].name for i in (*range(13), LOG_ID)}  # mixed: deadwood
    assert data["versions"]["wildscan"] and data["versions"]["dask"]
    assert data["runs"][-1]["bpy_imported_by_a_worker"] is False  # workers stay Blender-free


# --------------------------------------------------------------------------- poses and frames


@pytest.fixture(scope="module")
def world():
    from wildscan.app.poses import plan_backend
    from wildscan.core.world import plan_world

    plan = plan_world(2, "low")
    return plan, plan_backend(plan)


def accept_with(backend):
    from wildscan.core.errors import PoseRejected
    from wildscan.core.placement import place

    def accept(c):
        try:
            place(backend, c.pose, c.z_start)
        except PoseRejected:
            return False
        return True

    return accept


@pytest.mark.slow
def test_poses_are_seeded_spread_and_follow_the_zone_quotas(world):
    from wildscan.core.posesampler import sample_poses, zone_quotas

    plan, backend = world
    weights = {"forest": 2.0, "park": 1.0, "cave": 1.0}
    poses = sample_poses(plan, 12, "zones", weights, 3.0, accept_with(backend))
    assert poses == sample_poses(plan, 12, "zones", weights, 3.0, accept_with(backend))
    assert zone_quotas(weights, 12) == {"forest": 6, "park": 3, "cave": 3}
    assert [p.zone for p in poses].count("forest") == 6 and poses[0].zone == "forest"
    xy = np.array([(p.x, p.y) for p in poses])
    gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1)) + np.eye(len(xy)) * 1e9
    assert gaps.min() >= 3.0
    assert any(p.z_start is not None for p in poses)  # the cave interior (a reserved site) is used
    uniform = sample_poses(plan, 6, "uniform", weights, 3.0, accept_with(backend))
    assert len({p.zone for p in uniform}) > 1 and all(p.kind == "random" for p in uniform)


@pytest.mark.slow
def test_a_full_zone_reports_its_scans_instead_of_dropping_them(world):
    from wildscan.core.posesampler import NoPose, sample_poses

    plan, backend = world
    poses = sample_poses(plan, 40, "zones", {"cave": 1.0}, 30.0, accept_with(backend))
    missing = [p for p in poses if isinstance(p, NoPose)]
    assert missing and len(poses) == 40
    assert "no valid pose left in zone cave" in missing[0].reason


@pytest.mark.slow
@pytest.mark.parametrize("frame", ["leveled", "sensor"])
def test_points_of_any_frame_go_back_to_the_world_exactly(world, frame):
    from wildscan.core.placement import Pose
    from wildscan.core.scan import run_scan
    from wildscan.core.sensors import SensorConfig
    from wildscan.core.truth.groundtruth import pose_matrix, world_points

    plan, backend = world
    site = next(s for s in plan.sites if s.zone == "forest")
    sensor = SensorConfig(rh_deg=6.0, noise_sigma=0.01, noise_seed=3)
    pose = Pose(site.x, site.y, site.yaw_deg)
    in_frame = run_scan(backend, pose, sensor, frame)
    in_world = run_scan(backend, pose, sensor, "world")
    np.testing.assert_allclose(
        world_points(in_frame.cloud.xyz, in_frame.placement, frame), in_world.cloud.xyz, atol=1e-9
    )
    m = pose_matrix(in_frame.placement, frame)
    np.testing.assert_allclose(in_frame.cloud.xyz @ m[:3, :3].T + m[:3, 3], in_world.cloud.xyz, atol=1e-9)


def test_a_full_disk_while_writing_a_scan_leaves_none_of_its_files(tmp_path, monkeypatch):
    import errno
    from pathlib import Path

    from wildscan.app.dataset.worker import write_scan

    real = Path.write_bytes
    calls = []

    def fill_up(self, data):
        calls.append(self.name)
        if len(calls) == 3:
            real(self, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device", str(self))
        return real(self, data)

    monkeypatch.setattr(Path, "write_bytes", fill_up)
    files = {f"sequences/00/{kind}/000000.bin": bytes(1000) for kind in ("velodyne", "labels", "hag", "bev")}
    with pytest.raises(UserError, match="cannot write .*hag/000000.bin: No space left on device"):
        write_scan(tmp_path, files)
    assert [p for p in tmp_path.rglob("*") if p.is_file()] == []


@pytest.mark.parametrize("connected", [False, True])
def test_a_connect_that_runs_out_of_time_inside_dask_reads_as_no_answer(monkeypatch, connected):
    """Dask's connect wraps its own timeout (a cancelled wait) in an OSError; on a loaded
    machine that, not the overall bound, ends the probe: its line must still say the address
    did not answer in time, not name the CancelledError."""
    import asyncio

    import distributed.comm

    from wildscan.app.dataset import cluster
    from wildscan.core.errors import UserError

    class Comm:
        async def write(self, message):
            pass

        async def read(self):
            raise _timed_out()

        def abort(self):
            pass

    def _timed_out() -> OSError:
        try:
            raise asyncio.CancelledError()
        except asyncio.CancelledError as cancelled:
            try:
                raise OSError("Timed out trying to connect to tcp://127.0.0.1:9 after 5 s") from cancelled
            except OSError as e:
                return e

    async def connect(address, timeout):
        if connected:
            return Comm()
        raise _timed_out()

    monkeypatch.setattr(distributed.comm, "connect", connect)
    with pytest.raises(UserError) as error:
        cluster.probe_scheduler("tcp://127.0.0.1:9", seconds=2)
    expected = "did not answer as a Dask scheduler within 2 s" if connected else "no connection within 2 s"
    assert expected in str(error.value) and "CancelledError" not in str(error.value)
