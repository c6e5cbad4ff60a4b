"""Detection by received power (core/sensors/detection.py, core/lost_returns.py): every device
file carries a valid [detection] table, the realistic model sees a flat target of its datasheet's
reflectance to its datasheet's range within 5 % and no farther, the loss near the limit is
seeded, and a scan records what it lost."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from wildscan.bench.detection import QUICK_TARGET_BEAMS, returned_share
from wildscan.core.errors import UserError
from wildscan.core.placement import Pose
from wildscan.core.realism.lost_returns import Detecting, received_power, speckle, tally, tally_stats
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig, device_named, load_device, preset_names
from wildscan.core.sensors.detection import REFERENCE_REFLECTANCES
from wildscan.core.sensors.load import PRESETS_DIR, device_from_text

from tests.helpers.analytic import AnalyticBackend, Patch

EXAMPLES = sorted((PRESETS_DIR.parent / "examples").glob("*.toml"))
TOLERANCE = 0.05


@pytest.mark.parametrize("path", [PRESETS_DIR / f"{n}.toml" for n in preset_names()] + EXAMPLES, ids=str)
def test_every_device_file_has_a_detection_table_of_rising_pairs(path: Path):
    table = load_device(path).detection
    assert table is not None, f"{path.name} has no [detection] table"
    assert len(table.pairs) >= 1
    assert all(0 < rho <= 1 and r > 0 for rho, r in table.pairs)
    assert list(table.reflectance) == sorted(table.reflectance)
    assert list(table.range_m) == sorted(table.range_m)
    # a datasheet pair is met exactly by the threshold it fixes
    for rho, r in table.pairs:
        assert table.farthest_range(rho) == pytest.approx(r, rel=1e-9)


@pytest.mark.parametrize("name", preset_names())
@pytest.mark.parametrize("rho", REFERENCE_REFLECTANCES)
def test_a_flat_target_is_seen_to_the_datasheet_range_within_5_percent_and_no_farther(name, rho):
    """A cheap run of `wildscan bench --suite detection`: a wall at normal incidence scanned by
    the realistic model, at 0.95 and 1.05 times the range the table gives for `rho`."""
    device = device_named(name)
    limit = device.detection.farthest_range(rho)
    near = returned_share(device, rho, (1 - TOLERANCE) * limit, QUICK_TARGET_BEAMS)
    far = returned_share(device, rho, (1 + TOLERANCE) * limit, QUICK_TARGET_BEAMS)
    assert near >= 0.5 > far
    # past the speckle's reach (1.15 in power: 7.2 % in range by 1/R^2 alone) nothing returns
    assert returned_share(device, rho, 1.08 * limit, QUICK_TARGET_BEAMS) == 0.0
    # and well inside the limit everything does
    assert returned_share(device, rho, 0.9 * limit, QUICK_TARGET_BEAMS) == 1.0


def test_the_hdl64e_datasheet_pairs_fix_a_limit_between_them():
    table = device_named("hdl64e").detection
    assert table.pairs == ((0.10, 50.0), (0.80, 120.0))
    # between the pairs the limit is log-log linear: 30 % falls between 50 and 120 m
    assert 50.0 < table.farthest_range(0.3) < 120.0
    # a brighter target than any pair reaches farther, by the last segment's slope
    assert table.farthest_range(1.0) > 120.0
    # extinction shortens the range: fog of 1 km visibility (alpha = 3.912 / 1000)
    assert table.farthest_range(0.8, alpha=3.912e-3) < 0.8 * 120.0


@pytest.mark.parametrize(
    "detection, wrong",
    [
        ("pairs = [[0.8, 50.0], [0.1, 120.0]]", "pairs"),  # a darker target seen farther
        ("pairs = [[0.1, 50.0], [0.8, 40.0]]", "pairs"),
        ("pairs = [[1.5, 50.0]]", "pairs"),
        ("pairs = []", "pairs"),
        ("pairs = [[0.1, 50.0]]\nestimate = [0.2]", "estimate"),
        ("pairs = [[0.1, 50.0]]\nrange = 3", "unknown key"),
    ],
)
def test_a_wrong_detection_table_is_a_user_error_naming_the_key(detection, wrong):
    text = (PRESETS_DIR / "vlp16.toml").read_text()
    text = text[: text.index("[detection]")] + "[detection]\n" + detection + "\n"
    with pytest.raises(UserError) as e:
        device_from_text(text, "mine.toml")
    assert "mine.toml" in str(e.value) and wrong in str(e.value)


def test_the_received_power_is_the_lambertian_law_with_extinction():
    assert received_power(0.5, 1.0, 10.0) == pytest.approx(0.5 / 100)
    assert received_power(0.5, 0.5, 10.0) == pytest.approx(0.25 / 100)
    assert received_power(0.5, 1.0, 20.0) == pytest.approx(0.5 / 400)
    assert received_power(0.5, 1.0, 10.0, alpha=0.01) == pytest.approx(0.5 / 100 * np.exp(-0.2))


def test_the_speckle_is_seeded_and_spans_its_documented_range():
    beam, rank = np.arange(10_000), np.zeros(10_000, dtype=np.int64)
    a, b = speckle(3, beam, rank), speckle(3, beam, rank)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, speckle(4, beam, rank))
    assert 0.85 <= a.min() < 0.86 and 1.14 < a.max() <= 1.15


def test_the_tally_counts_weighed_and_lost_by_class_range_and_incidence():
    label = np.array([1, 1, 9, 9])
    distance = np.array([5.0, 15.0, 50.0, 150.0])
    cover = np.array([1.0, np.cos(np.radians(50)), 0.2, 1.0])
    lost = np.array([False, True, True, False])
    s = tally_stats(tally(label, distance, cover, lost)[0])
    assert (s["weighed"], s["lost"]) == (4, 2)
    assert s["by_class"] == {"1": [2, 1], "9": [2, 1]}
    assert s["by_range"] == {"0-10 m": [1, 0], "10-20 m": [1, 1], "40-60 m": [1, 1], ">100 m": [1, 0]}
    assert s["by_incidence"] == {"0-30 deg": [2, 0], "45-60 deg": [1, 1], ">75 deg": [1, 1]}


def wall_scene(distance: float) -> AnalyticBackend:
    """Ground, and a wall facing the sensor `distance` m along +X."""
    return AnalyticBackend(
        [
            Patch((0, 0, 0), (0, 0, 1), 1),
            Patch((distance, 0, 0), (-1, 0, 0), 6, instance=4, xy_box=(distance - 1, distance + 1, -40, 40)),
        ]
    )


def test_a_realistic_scan_loses_the_far_dark_returns_and_says_so():
    """The VLP-16 on flat ground: the ground at grazing incidence fades with range, so far
    beams are lost; the paper model (and the step off) keeps them; the scan says what it lost,
    and the same seed loses the same beams."""
    scene = wall_scene(200.0)
    sensor = SensorConfig.for_device(device_named("vlp16"), model="realistic", rh_deg=1.0)
    pose = Pose(0.0, 0.0, 0.0)
    with_step = run_scan(scene, pose, sensor, world_seed=5)
    without = run_scan(scene, pose, replace(sensor, detection=False), world_seed=5)
    lost = with_step.metadata["echoes"]["lost_returns"]
    # every echo formed is weighed (the strongest mode then keeps one a beam of those detected)
    assert lost["lost"] > 0 and lost["weighed"] >= len(without.cloud) > len(with_step.cloud)
    # the beams left without a point: a grazing footprint spans metres of ground, two echoes
    rows, columns = with_step.lost_cells
    assert 0 < len(rows) <= lost["lost"]
    # a lost cell holds no point: its beam returned nothing
    has_point = set(zip(with_step.cloud.ring.tolist(), with_step.cloud.extra["column"].tolist(), strict=True))
    assert not has_point & set(zip(rows.tolist(), columns.tolist(), strict=True))
    assert without.lost_cells is None
    # what is lost is far: no ground point within 10 m is lost, most beyond 40 m are
    assert lost["by_range"]["0-10 m"][1] == 0
    far = [v for k, v in lost["by_range"].items() if k in ("40-60 m", "60-80 m", "80-100 m")]
    assert sum(g for _, g in far) > 0.5 * sum(w for w, _ in far)
    assert with_step.cloud.range.max() < without.cloud.range.max()
    again = run_scan(scene, pose, sensor, world_seed=5)
    assert all(np.array_equal(a, b) for a, b in zip(again.lost_cells, with_step.lost_cells, strict=True))
    assert "lost_returns" not in without.metadata["echoes"]
    assert with_step.metadata["sensor"]["detection"][0]["range_m"] == 41.7


def test_an_objects_own_reflectance_decides_its_detection():
    """A wall at 60 m: white (0.9) returns, black (0.02) is lost, with the same class."""
    device = device_named("hdl64e")
    assert returned_share(device, 0.9, 60.0, 8) == 1.0
    assert returned_share(device, 0.02, 60.0, 8) == 0.0
    d = Detecting(device.detection, 0, 0, reflectances=((6, 4, 0.02), (6, 5, 0.9)))
    assert np.allclose(
        d.override(np.array([6, 6, 6, 1]), np.array([4, 5, 6, 4])),
        [0.02, 0.9, np.nan, np.nan],
        equal_nan=True,
    )
