"""The mount height, a setting of its own (issue 35): `[mount] height` in a device file,
`--mount-height` on `scan` and `drive`, `[sensor] mount_height` and `like` in SPEC.toml. The
default is the paper robot's 0.723 m column, whose files keep their bytes."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.app.dataset import spec_from_dict
from wildscan.app.dataset.draws import draw_sensor
from wildscan.app.dataset.like import LIKES
from wildscan.core import placement as P
from wildscan.core.errors import UserError
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig, device_named
from wildscan.core.sensors.load import PRESETS_DIR, device_from_text

from tests.helpers.analytic import AnalyticBackend, Patch, slope_plane
from tests.helpers.dataset_helpers import wildscan


def vlp16_text(extra: str = "") -> str:
    return (PRESETS_DIR / "vlp16.toml").read_text(encoding="utf-8") + extra


@pytest.mark.parametrize("height", [0.5, 1.73, 3.0])
def test_the_optical_centre_stands_at_the_mount_height_up_the_tilted_column(height):
    """On a plane of known slope the optical centre is `height` along the plane's normal from
    the ground centre, and in the sensor frame the ground is the plane z = -height."""
    ground = slope_plane(0.4, 0.1, -0.05, class_id=1)
    sensor = SensorConfig(noise_sigma=0.0, rh_deg=4.0, mount_height=height)
    result = run_scan(AnalyticBackend([ground]), P.Pose(1.0, 2.0, 30.0), sensor, frame="sensor")
    placement = result.placement
    column = placement.optical_centre - placement.ground_centre
    normal = np.array([-0.1, 0.05, 1.0]) / np.linalg.norm([-0.1, 0.05, 1.0])
    assert np.linalg.norm(column) == pytest.approx(height) and column @ normal == pytest.approx(height)
    assert np.allclose(result.cloud.xyz[:, 2], -height, atol=1e-9)
    assert placement.to_dict()["column_height"] == height
    assert result.metadata["sensor"]["mount_height"] == height


def test_the_paper_column_says_nothing_new_in_the_metadata():
    sensor = SensorConfig(noise_sigma=0.0, rh_deg=4.0)
    assert sensor.mount_height == P.COLUMN_HEIGHT == 0.723 and "mount_height" not in sensor.to_dict()


@pytest.mark.parametrize("height", [P.COLUMN_HEIGHT, 2.5])
def test_a_vlp16_meets_flat_ground_first_at_its_height_over_tan_15_deg(height):
    """The lowest ring (-15 deg) reaches the ground h / tan 15 deg away: a mast pushes the
    nearest ground return out as it raises the sensor."""
    sensor = SensorConfig.for_device(device_named("vlp16"), noise_sigma=0.0, mount_height=height)
    cloud = run_scan(AnalyticBackend([Patch((0, 0, 0), (0, 0, 1), 1)]), P.Pose(0, 0, 0), sensor).cloud
    reach = np.hypot(cloud.xyz[:, 0], cloud.xyz[:, 1])
    assert reach.min() == pytest.approx(height / np.tan(np.radians(15.0)), rel=1e-6)
    assert np.allclose(cloud.xyz[:, 2], -height, atol=1e-9)


def test_a_device_file_carries_its_mount_height_and_a_scan_may_change_it():
    device = device_from_text(vlp16_text().replace("[mount]\n", "[mount]\nheight = 1.8\n"), "mast.toml")
    assert device.mount.height_m == 1.8
    assert SensorConfig.for_device(device).mount_height == 1.8
    assert SensorConfig.for_device(device, mount_height=0.5).mount_height == 0.5
    assert SensorConfig.for_device(device_named("vlp16")).mount_height == P.COLUMN_HEIGHT
    with pytest.raises(UserError, match=r"mount.height must be a number from 0.1 to 10, got 12"):
        device_from_text(vlp16_text().replace("[mount]\n", "[mount]\nheight = 12\n"), "mast.toml")
    with pytest.raises(UserError) as info:
        SensorConfig(mount_height=0.0).validate()
    assert info.value.setting == "mount_height" and "from 0.1 to 10 m" in str(info.value)


def test_a_spec_sets_draws_and_checks_the_mount_height():
    spec = spec_from_dict({"sensor": {"mount_height": [1.0, 2.0]}})
    heights = {draw_sensor(spec.sensor, 4, k).mount_height for k in range(10)}
    assert len(heights) == 10 and all(1.0 <= h <= 2.0 for h in heights)
    assert heights == {draw_sensor(spec.sensor, 4, k).mount_height for k in range(10)}
    # without it, the spec (and so its config hash) is what it was
    assert "mount_height" not in spec_from_dict({}).to_dict()["sensor"]
    assert draw_sensor(spec_from_dict({}).sensor, 4, 0).mount_height == P.COLUMN_HEIGHT
    with pytest.raises(UserError, match="sensor.mount_height must be a number from 0.1 to 10 m"):
        spec_from_dict({"sensor": {"mount_height": 20.0}})


@pytest.mark.parametrize("name", sorted(LIKES))
def test_like_sets_the_rig_height_labels_and_files_and_explicit_keys_win(name):
    like = LIKES[name]
    spec = spec_from_dict({"like": name})
    assert spec.sensor.device == like.device and spec.sensor.mount_height == like.mount_height
    assert spec.label_scheme == like.label_scheme and spec.formats == like.formats
    assert draw_sensor(spec.sensor, 1, 0).mount_height == like.mount_height
    mine = spec_from_dict({"like": name, "label_scheme": "wildscan", "sensor": {"mount_height": 0.9}})
    assert mine.label_scheme == "wildscan" and mine.sensor.mount_height == 0.9
    assert mine.sensor.device == like.device


def test_like_names_the_datasets_and_their_primary_lidars():
    assert {n: (lk.device, lk.mount_height) for n, lk in LIKES.items()} == {
        "rellis3d": ("os1-64", 1.14),
        "goose": ("vls128", 2.0),
        "wildscenes": ("wildscenes", 1.2),
        "semantickitti": ("hdl64e", 1.73),
    }
    with pytest.raises(UserError, match='like must be one of "rellis3d", "goose"'):
        spec_from_dict({"like": "kitti"})


def test_the_command_line_takes_mount_height_and_like_as_one_line_errors(tmp_path):
    done = wildscan("scan", "--seed", "1", "--pose", "0", "0", "0", "--mount-height", "50", "--out", "x.ply")
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "--mount-height must be from 0.1 to 10 m, got 50" in done.stderr
    done = wildscan("dataset", "--like", "kitti", "--out", str(tmp_path / "out"))
    assert done.returncode == 2
    assert "--like must be one of rellis3d, goose, wildscenes, semantickitti" in done.stderr
    assert not (tmp_path / "out").exists()
    help_text = wildscan("drive", "--help").stdout
    assert "--mount-height M" in help_text


def test_a_drives_imu_extrinsics_follow_the_mount_height():
    """calib.txt's Tr_imu_to_velo: the IMU (0.35 m up base_link) seen from the sensor frame,
    which stands at the mount height (0.723 m by default: -0.373 m; on a 1.5 m mast -1.15 m)."""
    from wildscan.app.drive.imu import DriveImu
    from wildscan.core.motion.imu_models import DEFAULT_MOUNT, MODELS

    empty = np.zeros((0, 3))
    args = (next(iter(MODELS.values())), 200, False, DEFAULT_MOUNT, np.zeros(0, np.int64), np.zeros((0, 4)))
    column = DriveImu(*args, empty, empty).sensor_from_imu()
    mast = DriveImu(*args, empty, empty, sensor_height=1.5).sensor_from_imu()
    assert column[2, 3] == pytest.approx(DEFAULT_MOUNT.translation[2] - 0.723)
    assert mast[2, 3] == pytest.approx(DEFAULT_MOUNT.translation[2] - 1.5)
    assert np.array_equal(np.delete(column, 11), np.delete(mast, 11))  # nothing else moves
