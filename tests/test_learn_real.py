"""`wildscan bench --suite learn TRAIN_DIR --test REAL_DIR --scheme NAME` (bench/learn_real.py):
real folders in their datasets' own layouts (written here from a small WildScan dataset: no real
data in the repository), read as those datasets' tools read them (numpy.fromfile of float32
points and SemanticKITTI / WildScenes labels), scored over the classes both share."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from wildscan.bench import learn_real as R
from wildscan.core.errors import UserError
from wildscan.core.label_schemes import scheme

from tests.helpers.dataset_helpers import wildscan, written_dataset

pytest.importorskip("sklearn")
pytestmark = pytest.mark.slow  # a small dataset, then the baseline trained twice

TRAIN_SPEC = """\
layout = "paper"
seeds = [3]
scans_per_world = 4
formats = ["semantickitti"]
label_scheme = "wildscan"
detail = "low"
split = { train = 1.0 }

[sensor]
rh = 4.0
"""


@pytest.fixture(scope="module")
def train(tmp_path_factory) -> Path:
    root, _ = written_dataset(tmp_path_factory.mktemp("train"), TRAIN_SPEC)
    return root


def wildscan_scans(root: Path):
    """(level xyz, remission, WildScan ids) of every scan of a dataset, in manifest order."""
    rows = [json.loads(line) for line in (root / "manifest.jsonl").read_text().splitlines()]
    for row in (r for r in rows if r["status"] == "ok"):
        path = next(f["path"] for f in row["files"] if "/velodyne/" in f["path"])
        points = np.fromfile(root / path, dtype="<f4").reshape(-1, 4)
        labels = np.fromfile(root / path.replace("/velodyne/", "/labels/").replace(".bin", ".label"), "<u4")
        rotation = np.array(row["pose_matrix"]).reshape(3, 4)[:, :3]
        yield (points[:, :3] @ rotation.T).astype("<f4"), points[:, 3], labels & 0xFFFF


def write_real(root: Path, train: Path, layout: str) -> Path:
    """The train dataset's scans re-written as a real folder of `layout`, in its scheme's ids."""
    name = {"semantickitti": "semantickitti", "rellis3d": "rellis3d", "goose": "goose"}.get(layout, layout)
    ids = scheme(name).lookup()
    for k, (xyz, remission, wildscan_ids) in enumerate(wildscan_scans(train)):
        raw = ids[wildscan_ids].astype(np.uint32)
        if layout == "semantickitti":
            cloud, label = root / "sequences/00/velodyne" / f"{k:06d}.bin", root / "sequences/00/labels"
            label = label / f"{k:06d}.label"
        elif layout == "rellis3d":
            cloud = root / "00000/os1_cloud_node_kitti_bin" / f"{k:06d}.bin"
            label = root / "00000/os1_cloud_node_semantickitti_label_id" / f"{k:06d}.label"
        elif layout == "goose":
            stem = f"2022-07-22_flight__{k:04d}_16584942343343{k:05d}"
            cloud = root / "lidar/val/2022-07-22_flight" / f"{stem}_vls128.bin"
            label = root / "labels/val/2022-07-22_flight" / f"{stem}_goose.label"
        else:  # wildscenes: x y z only, int32 ids
            cloud, label = root / "V-01/Clouds" / f"{k:04d}.bin", root / "V-01/Labels" / f"{k:04d}.label"
        cloud.parent.mkdir(parents=True, exist_ok=True)
        label.parent.mkdir(parents=True, exist_ok=True)
        if layout == "wildscenes":
            xyz.tofile(cloud)
            raw.astype("<i4").tofile(label)
        else:
            np.column_stack([xyz, remission]).astype("<f4").tofile(cloud)
            (raw | (np.uint32(7) << np.uint32(16))).astype("<u4").tofile(
                label
            )  # an instance in the high bits
    return root


@pytest.mark.parametrize("layout", ["semantickitti", "rellis3d", "goose", "wildscenes"])
def test_each_layout_is_found_and_read_as_its_dataset_writes_it(train, tmp_path, layout):
    real = write_real(tmp_path / layout, train, layout)
    found, pairs = R.find_real_scans(real)
    assert found.name == layout and len(pairs) == 4
    xyz, remission, raw = R.read_real_scan(found, *pairs[0])
    first = next(wildscan_scans(train))
    assert np.array_equal(xyz, first[0]) and len(raw) == len(xyz)
    assert (remission is None) == (layout == "wildscenes")
    assert np.array_equal(raw, scheme(layout).lookup()[first[2]])  # the instance bits are dropped


def test_rellis3d_transfer_prints_per_class_iou_for_the_real_folder(train, tmp_path):
    """The issue's bar. The 'real' scans are the training worlds' own scans here, so the
    WildScan-trained model must do well on them, and the classes scored are RELLIS-3D's."""
    real = write_real(tmp_path / "rellis", train, "rellis3d")
    done = wildscan("bench", "--suite", "learn", str(train), "--test", str(real), "--scheme", "rellis3d")
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "rellis3d layout, rellis3d ids: the later 2 of its scans; the earlier 2 train the ceiling" in out
    rows = {ln.split("|")[1].strip(): ln for ln in out.splitlines() if ln.startswith("| ") and "%" in ln}
    assert {"grass", "tree"} <= set(rows) and set(rows) <= set(scheme("rellis3d").labels.values())
    ious = [float(ln.split("|")[5].strip(" %")) for ln in rows.values()]
    assert all(0.0 <= v <= 100.0 for v in ious)
    miou = float(out.split("shared classes: WildScan -> real ")[1].split(" %")[0])
    assert miou > 50.0  # scored on scans it trained on


def test_a_transfer_scores_the_shared_classes_only(train, tmp_path):
    real = write_real(tmp_path / "ws", train, "wildscenes")
    result = R.bench_transfer(train, real, "wildscenes")
    names = [n for _, n in result.classes]
    assert "sky" not in names and "water" not in names  # ignored by WildScenes' benchmark
    assert set(result.iou) == set(result.ceiling_iou) == {c for c, _ in result.classes}
    assert all(result.test_points[c] > 0 and result.train_points[c] > 0 for c, _ in result.classes)
    assert result.scans == {"wildscan": 4, "ceiling": 2, "test": 2}


def test_iou_counts_a_wrong_prediction_against_both_classes():
    truth = np.array([1, 1, 2, 2])
    predicted = np.array([1, 2, 2, 2])
    assert R.iou_over([1, 2], truth, predicted) == {1: 0.5, 2: 2 / 3}


def test_bad_real_folders_and_options_are_one_line_errors(train, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(UserError, match="holds no labelled scans in a layout the suite reads"):
        R.find_real_scans(empty)
    real = write_real(tmp_path / "short", train, "rellis3d")
    layout, pairs = R.find_real_scans(real)
    cloud, label = pairs[0]
    label.write_bytes(label.read_bytes()[:-4])  # one point's label short
    with pytest.raises(UserError, match="do not hold the same points"):
        R.read_real_scan(layout, cloud, label)
    done = wildscan("bench", "--suite", "learn", str(train), "--test", str(real))
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "--scheme NAME" in done.stderr
    done = wildscan("bench", "--suite", "learn", str(train), "--test", str(empty), "--scheme", "goose")
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "no labelled scans" in done.stderr
    done = wildscan("bench", "--suite", "devices", "--test", str(empty))
    assert done.returncode == 2 and "--test applies to --suite learn only" in done.stderr
