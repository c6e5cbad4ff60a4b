"""`wildscan bench --suite learn DIR` (bench/learn.py, bench/learn_features.py): features that
mean what they say on shapes whose answer is known, IoU as defined, class-aware sampling,
a clear refusal without a train and a test split, and the command on a small dataset."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wildscan.bench import learn as L
from wildscan.bench.learn_features import _cells, feature_names, scan_features
from wildscan.core.errors import UserError

from tests.helpers.dataset_helpers import wildscan, written_dataset

pytest.importorskip("sklearn")


def ground_and_pole(n: int = 4000):
    """A flat ground at z = -1.5 m (the sensor 1.5 m above it) and a pole 3 m tall at x = 4."""
    rng = np.random.default_rng(0)
    ground = np.column_stack([rng.uniform(-10, 10, n), rng.uniform(-10, 10, n), np.full(n, -1.5)])
    t = rng.uniform(0, 3, n // 4)
    a = rng.uniform(0, 2 * np.pi, n // 4)
    pole = np.column_stack([4 + 0.05 * np.cos(a), 0.05 * np.sin(a), -1.5 + t])
    return np.vstack([ground, pole]), n


def feature(feats: np.ndarray, name: str) -> np.ndarray:
    return feats[:, feature_names().index(name)]


def test_features_tell_ground_from_a_pole_in_the_worlds_axes_whatever_the_frame():
    xyz, n = ground_and_pole()
    feats = scan_features(xyz, np.eye(3))
    assert feats.shape == (len(xyz), len(feature_names()))
    assert np.abs(feature(feats, "above_lowest_0.5m")[:n]).max() < 1e-6  # the ground is its own lowest
    assert np.median(feature(feats, "above_lowest_0.5m")[n:]) > 1.0  # the pole stands above it
    scattering = feature(feats, "scattering_1m")[:n]  # -1: a voxel of fewer than 3 points
    assert (scattering < 1e-6).mean() > 0.99 and (scattering == 0).mean() > 0.9  # flat (but by the pole)
    assert np.median(feature(feats, "verticality_1m")[:n]) < 0.05  # a horizontal plane's normal is up
    assert np.median(feature(feats, "linearity_1m")[n:]) > 0.8
    np.testing.assert_allclose(feature(feats, "z_sensor")[:n], -1.5, atol=1e-6)
    # points in a frame turned 30 deg about Z (the dataset's pose turns them back): the same features
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    turned = scan_features(xyz @ rot, rot)  # p_frame = R^T p_world, row-wise p @ R
    np.testing.assert_allclose(feature(turned, "z_sensor"), feature(feats, "z_sensor"), atol=1e-5)
    np.testing.assert_allclose(feature(turned, "range"), feature(feats, "range"), atol=1e-4)


def test_features_of_picked_points_equal_those_of_the_whole_scan():
    xyz, _ = ground_and_pole(2000)
    pick = np.arange(0, len(xyz), 7)
    np.testing.assert_array_equal(
        scan_features(xyz, np.eye(3), pick=pick), scan_features(xyz, np.eye(3))[pick]
    )


def test_intensity_is_a_feature_only_when_asked():
    xyz, _ = ground_and_pole(500)
    remission = np.linspace(0, 1, len(xyz))
    assert "remission" not in feature_names()
    with_it = scan_features(xyz, np.eye(3), remission)
    assert with_it.shape[1] == len(feature_names(True)) == len(feature_names()) + 1
    np.testing.assert_allclose(with_it[:, -1], remission, atol=1e-7)


def test_cells_group_rows_as_numpys_unique_over_rows_does():
    keys = np.random.default_rng(1).integers(-5, 5, size=(3000, 3))
    ours, n = _cells(keys)
    _, theirs = np.unique(keys, axis=0, return_inverse=True)
    assert n == len(np.unique(keys, axis=0))
    np.testing.assert_array_equal(ours, theirs.ravel())  # both sort rows lexicographically


def test_iou_is_tp_over_tp_fp_fn_and_miou_averages_the_classes_with_test_points():
    ds = L.LearnDataset(root=None, learning_map={0: 0, 1: 1, 2: 2}, ignored=frozenset({0}),
                        names={0: "unlabeled", 1: "a", 2: "b"}, rows=())  # fmt: skip
    truth = np.array([1, 1, 1, 2, 2])
    predicted = np.array([1, 1, 2, 2, 2])
    result = L.score(ds, np.array([1, 2]), truth, predicted, "test", False)
    assert result.iou == {1: pytest.approx(2 / 3), 2: pytest.approx(2 / 3)}
    assert result.confusion.tolist() == [[2, 1], [0, 2]]
    assert result.miou == pytest.approx(2 / 3)


def test_class_aware_sampling_caps_each_class_keeps_rare_ones_and_is_seeded():
    from wildscan.core.rng import stage_rng

    label = np.array([1] * 5000 + [2] * 30 + [0] * 100)
    pick = L.train_sample(label, frozenset({0}), stage_rng(1, "x"), 200)
    assert (label[pick] == 1).sum() == 200 and (label[pick] == 2).sum() == 30 and not (label[pick] == 0).any()
    np.testing.assert_array_equal(pick, L.train_sample(label, frozenset({0}), stage_rng(1, "x"), 200))
    assert L.train_per_class(480, 12) == L.MIN_PER_CLASS and L.train_per_class(20, 12) == 500


def test_a_dataset_without_a_test_or_val_world_is_refused_in_one_line():
    ds = L.LearnDataset(root="DIR", learning_map={0: 0, 1: 1}, ignored=frozenset({0}),
                        names={1: "a"}, rows=({"split": "train"},))  # fmt: skip
    with pytest.raises(UserError) as e:
        L.collect(ds, False)
    assert "has scans in train only" in str(e.value) and "\n" not in str(e.value)
    no_train = dataclasses.replace(ds, rows=({"split": "test"},))
    with pytest.raises(UserError):
        L.collect(no_train, False)


# --------------------------------------------------------------------------- the command

TINY = """\
layout = "paper"
seeds = [1, 2]
scans_per_world = 2
formats = ["semantickitti"]
split = { train = 0.5, test = 0.5 }

[poses]
zones = { forest = 1, park = 1 }

[sensor]
rh = 6.0
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return written_dataset(tmp_path_factory.mktemp("learn"), TINY, out="data")[0]


@pytest.mark.slow
def test_the_suite_prints_iou_per_class_miou_and_the_confusion_and_writes_the_card(tiny):
    first = wildscan("bench", "--suite", "learn", str(tiny), "--card")
    assert first.returncode == 0, first.stderr
    out = first.stdout
    for words in ("| terrain |", "mIoU ", "on the test split (geometry only, no intensity)", "Confusion"):
        assert words in out
    card = (tiny / "CARD.md").read_text()
    assert card.count("## Learnability") == 1 and "| terrain |" in card.split("## Learnability")[1]
    again = wildscan("bench", "--suite", "learn", str(tiny), "--card")
    assert again.returncode == 0
    table = out[out.index("| class |") : out.index("Confusion")]
    assert table in again.stdout  # the same figures: seeded sampling, fixed model, one thread
    assert (tiny / "CARD.md").read_text().count("## Learnability") == 1  # replaced, not added
    verify = wildscan("dataset", "--verify", str(tiny))
    assert verify.returncode == 0, verify.stdout


@pytest.mark.slow
def test_with_intensity_adds_remission_and_says_so(tiny):
    run = wildscan("bench", "--suite", "learn", str(tiny), "--with-intensity")
    assert run.returncode == 0, run.stderr
    assert "(geometry and remission)" in run.stdout and f"{len(feature_names(True))} features" in run.stdout


@pytest.mark.parametrize(
    "args, words",
    [
        (["--suite", "learn"], "needs the dataset folder"),
        (["--suite", "learn", "/nonexistent/wild"], "is not a WildScan dataset"),
        (["--suite", "far", "--card"], "--card applies to --suite learn only"),
        (["--suite", "weather", "/tmp"], "measured by --suite learn only"),
    ],
)
def test_mistakes_exit_2_with_one_line(args, words):
    run = wildscan("bench", *args)
    assert run.returncode == 2 and words in run.stderr and len(run.stderr.strip().splitlines()) == 1
