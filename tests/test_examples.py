"""examples/wildscan_torch's data path, without torch: it reads a real dataset's files and
labels.yaml (learning map, class weights, split), and its spherical projection puts known
points where RangeNet++'s formula says."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.dataset_helpers import wildscan

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"


def load_data_module():
    spec = importlib.util.spec_from_file_location(
        "wildscan_torch_data", EXAMPLES / "wildscan_torch" / "data.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


D = load_data_module()


def test_the_data_path_imports_no_torch():
    code = (
        f"import sys; sys.path.insert(0, {str(EXAMPLES)!r}); import wildscan_torch.data; "
        "print('torch' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert out.stdout.strip() == "False"


def test_the_projection_puts_known_directions_on_their_pixels():
    xyz = np.array(
        [
            [5.0, 0.0, 0.0],  # ahead, on the horizon
            [0.0, 5.0, 0.0],  # left: a quarter turn of azimuth
            [-5.0, 0.0, 0.0],  # behind
            [0.0, 0.0, 5.0],  # straight up: the top row
        ]
    )
    row, col = D.pixel_of(xyz, 64, 512)
    horizon = int((1 - (0 - np.radians(D.FOV_DOWN_DEG)) / np.radians(D.FOV_UP_DEG - D.FOV_DOWN_DEG)) * 64)
    assert row.tolist() == [horizon, horizon, horizon, 0]
    assert col.tolist() == [256, 128, 0, 256]  # u = (1 - yaw/pi)/2 * W; behind (yaw = pi) is column 0


def test_the_nearest_point_of_a_pixel_wins_and_empty_pixels_are_ignored():
    xyz = np.array([[10.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    p = D.project(xyz, np.array([0.1, 0.2, 0.3]), np.array([1, 2, 3]), use_remission=True)
    assert p.image.shape == (5, D.HEIGHT, D.WIDTH) and p.mask.sum() == 2
    r, c = p.row[0], p.col[0]
    assert (p.row[1], p.col[1]) == (r, c)
    assert p.labels[r, c] == 2 and p.image[0, r, c] == pytest.approx(5.0 / D.RANGE_SCALE)
    assert p.image[4, r, c] == pytest.approx(0.2)  # its remission, the last channel
    assert p.labels[~p.mask].max() == 0  # 0: ignored by the loss


def test_iou_table_is_tp_over_tp_fp_fn_for_classes_with_points():
    confusion = np.array([[0, 0, 0], [0, 2, 1], [0, 0, 2]])
    assert D.iou_table(confusion, frozenset({0})) == {1: pytest.approx(2 / 3), 2: pytest.approx(2 / 3)}


TINY = """\
layout = "paper"
seeds = [1, 2]
scans_per_world = 1
formats = ["semantickitti"]
label_scheme = "semantickitti"
split = { train = 0.5, val = 0.5 }

[sensor]
rh = 10.0
"""


@pytest.mark.slow
def test_a_real_dataset_reads_with_its_learning_map_weights_and_split(tmp_path):
    (tmp_path / "spec.toml").write_text(TINY)
    made = wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(tmp_path / "data"), "--workers", "1")
    assert made.returncode == 0, made.stderr
    root = tmp_path / "data"
    config = D.load_label_config(root)
    assert config.split["train"] and config.split["valid"] and not config.split["test"]
    assert config.names[config.learning_map[72]] == "terrain" and 0 in config.ignore
    files = D.scan_files(root, config.split["train"]) + D.scan_files(root, config.split["valid"])
    assert len(files) == 2
    for bin_path, label_path in files:
        xyz, remission, labels = D.read_scan(bin_path, label_path, config)
        raw = np.fromfile(label_path, dtype="<u4") & 0xFFFF
        assert np.all(labels[raw == 72] == config.learning_map[72])  # terrain through the learning map
        assert 0.0 <= remission.min() and remission.max() <= 1.0
        p = D.project(xyz, remission, labels)
        assert p.mask.sum() > 1000 and set(np.unique(p.labels[p.mask])) <= set(np.unique(labels))
    weights = config.weight_vector()
    terrain = config.learning_map[72]
    assert weights[0] == 0.0 and 0 < weights[terrain] < weights.max()  # the commonest class weighs least


def test_the_learn_suites_dataset_spec_loads_as_docs_benchmarks_says():
    from wildscan.app.dataset.spec import load_spec

    spec = load_spec(EXAMPLES / "learn20.toml")
    assert len(spec.seeds) == 20 and spec.scans_per_world == 30 and spec.sensor.rh == 2.0
    assert dict(spec.poses.min_scans_with)["log"] == 0.25
    assert "examples/learn20.toml" in (REPO / "docs" / "benchmarks.md").read_text()


def test_the_transfer_figures_specs_load_as_docs_training_says():
    """The two datasets of docs/training.md's WildScan -> other-biome transfer: RELLIS-3D's rig
    and ids (like = "rellis3d"), mixed for training, forest as the 'real' folder."""
    from wildscan.app.dataset.spec import load_spec

    mixed, forest = (load_spec(EXAMPLES / f"transfer-{b}.toml") for b in ("mixed", "forest"))
    for spec in (mixed, forest):
        assert spec.sensor.device == "os1-64" and spec.sensor.mount_height == 1.14
        assert spec.label_scheme == "rellis3d" and spec.formats == ("semantickitti",)
    assert (mixed.biome, forest.biome) == ("mixed", "forest") and not set(mixed.seeds) & set(forest.seeds)
    page = (REPO / "docs" / "training.md").read_text()
    assert "examples/transfer-mixed.toml" in page and "examples/transfer-forest.toml" in page
