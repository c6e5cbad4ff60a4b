"""Range images on a scan's native grid (core/io/rangeimage.py): the cell of a point is its beam
(Eq. 1's n as the row, the 2D scan m as the column), read back with np.load."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest
from plyfile import PlyData

from wildscan.core.io.rangeimage import ARRAYS, NO_DATA, npz_bytes, range_image, scan_range_image
from wildscan.core.placement import Pose
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig

from tests.helpers.analytic import weather_scene
from tests.helpers.scene_helpers import PAPER, WILDSCAN, run, user_error_line

RH = 4.0  # 45 2D scans


@pytest.fixture(scope="module")
def sensor_scan():
    """A noiseless scan of flat ground and walls, in the sensor frame."""
    return run_scan(weather_scene(), Pose(0.0, 0.0, 0.0), SensorConfig(rh_deg=RH, noise_sigma=0.0), "sensor")


def _image(result) -> dict[str, np.ndarray]:
    cloud = result.cloud
    return scan_range_image(cloud, result.metadata, cloud.intensity / 100, cloud.label, cloud.instance)


def test_the_grid_is_the_beams_of_a_2d_scan_by_the_2d_scans(sensor_scan):
    image = _image(sensor_scan)
    assert image["range"].shape == (1080, 180 / RH)
    assert image["mask"].sum() == len(sensor_scan.cloud)  # one point a beam: none lost, none shared
    assert set(image) == set(ARRAYS)


def test_each_cell_holds_the_point_along_its_beams_direction_by_eq_1(sensor_scan):
    """Cell (n, m) holds the point at range ρ along Eq. 1's beam n of 2D scan m:
    ρ (cos φ sin θ, sin φ sin θ, cos θ), θ = n·0.25° − 135°, φ = m·r_h (sensor frame)."""
    image, cloud = _image(sensor_scan), sensor_scan.cloud
    n, m = np.nonzero(image["mask"])
    theta, phi = np.radians(n * 0.25 - 135.0), np.radians(m * RH)
    rho = image["range"][n, m].astype(np.float64)
    expected = rho[:, None] * np.stack(
        [np.cos(phi) * np.sin(theta), np.sin(phi) * np.sin(theta), np.cos(theta)], axis=1
    )
    held = image["index"][n, m]
    np.testing.assert_allclose(cloud.xyz[held], expected, atol=2e-5)
    np.testing.assert_array_equal(image["label"][n, m], cloud.label[held])
    np.testing.assert_allclose(image["intensity"][n, m], cloud.intensity[held] / 100, rtol=1e-6)


def test_each_point_names_its_cell(sensor_scan):
    image, cloud = _image(sensor_scan), sensor_scan.cloud
    row, column = image["row"], image["column"]
    assert len(row) == len(column) == len(cloud)
    np.testing.assert_array_equal(image["index"][row, column], np.arange(len(cloud)))
    np.testing.assert_array_equal(image["range"][row, column], cloud.range)


def test_empty_cells_say_so():
    image = range_image(
        np.array([0]), np.array([1]), (2, 3), np.array([5.0]), np.array([0.5]), np.array([9]), np.array([4])
    )
    assert image["mask"].tolist() == [[False, True, False], [False, False, False]]
    assert image["range"][1, 2] == image["intensity"][1, 2] == image["index"][1, 2] == NO_DATA
    assert image["label"][1, 2] == image["instance"][1, 2] == 0
    assert (image["range"][0, 1], image["label"][0, 1], image["instance"][0, 1]) == (5.0, 9, 4)


def test_a_cell_with_several_echoes_holds_the_nearest():
    row, column = np.array([1, 1, 1, 0]), np.array([0, 0, 0, 0])
    ranges = np.array([7.0, 3.0, 5.0, 2.0])
    image = range_image(row, column, (2, 1), ranges, ranges / 10, np.array([1, 2, 3, 4]), np.zeros(4))
    assert image["range"][1, 0] == 3.0 and image["label"][1, 0] == 2 and image["index"][1, 0] == 1
    assert image["index"][0, 0] == 3


def test_a_point_outside_the_grid_is_refused():
    with pytest.raises(ValueError, match="outside the 2 x 2 grid"):
        range_image(np.array([2]), np.array([0]), (2, 2), *(np.ones(1),) * 4)


def test_the_npz_is_the_same_bytes_every_time_and_numpy_reads_it(sensor_scan):
    image = _image(sensor_scan)
    data = npz_bytes(image)
    assert data == npz_bytes(_image(sensor_scan))
    with np.load(io.BytesIO(data)) as back:
        assert sorted(back.files) == sorted(ARRAYS)
        for name in ARRAYS:
            np.testing.assert_array_equal(back[name], image[name])
            assert back[name].dtype == image[name].dtype
    stamps = {info.date_time for info in zipfile.ZipFile(io.BytesIO(data)).infolist()}
    assert stamps == {(1980, 1, 1, 0, 0, 0)}


# --------------------------------------------------------------------------- wildscan scan --range-image

PARK_POSE_SEED_2_LOW = ("61.908", "-58.594", "126.6")  # `wildscan poses --seed 2 --detail low --zone park`


@pytest.fixture(scope="module")
def geometry(tmp_path_factory):
    """Seed 2 at low detail as a geometry file (planned without Blender)."""
    out = tmp_path_factory.mktemp("geometry") / "seed2.npz"
    done = run([WILDSCAN, "extract", *PAPER, "--seed", "2", "--detail", "low", "--out", str(out), "--quiet"])
    assert done.returncode == 0, done.stderr
    return out


def _scan(geometry, out, *extra: str):
    pose = ("--pose", *PARK_POSE_SEED_2_LOW, "--rh", "4", "--quiet")
    return run([WILDSCAN, "scan", "--geometry", str(geometry), *pose, *extra, "--out", str(out)])


@pytest.mark.slow
def test_scan_writes_the_range_image_of_the_ply_it_writes(geometry, tmp_path):
    plain = _scan(geometry, tmp_path / "plain.ply")
    done = _scan(geometry, tmp_path / "scan.ply", "--range-image", str(tmp_path / "image.npz"))
    assert plain.returncode == 0 and done.returncode == 0, done.stderr
    assert f"wrote {tmp_path / 'image.npz'}" in done.stdout
    # the PLY is today's, with or without its range image
    assert (tmp_path / "scan.ply").read_bytes() == (tmp_path / "plain.ply").read_bytes()
    vertex = PlyData.read(str(tmp_path / "scan.ply"))["vertex"]
    with np.load(tmp_path / "image.npz") as image:
        assert image["range"].shape == (1080, 45)
        np.testing.assert_array_equal(image["row"], vertex["ring"])
        np.testing.assert_array_equal(image["column"], vertex["sweep"])
        assert image["mask"].sum() == len(vertex["x"])
        cell = image["row"], image["column"]
        np.testing.assert_array_equal(image["range"][cell], vertex["range"])
        np.testing.assert_array_equal(image["label"][cell], vertex["label"])  # a PLY's ids: WildScan's
        np.testing.assert_array_equal(image["instance"][cell], vertex["instance"])
        np.testing.assert_allclose(image["intensity"][cell], vertex["intensity"] / 100, rtol=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize(
    "image, message",
    [
        ("image.png", "--range-image {dir}/image.png: the file name must end in .npz"),
        ("missing/image.npz", "--range-image {dir}/missing/image.npz: directory"),
    ],
)
def test_a_bad_range_image_path_exits_2_before_anything_is_written(geometry, tmp_path, image, message):
    done = _scan(geometry, tmp_path / "scan.ply", "--range-image", str(tmp_path / image))
    assert done.returncode == 2
    assert message.format(dir=tmp_path) in user_error_line(done)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_semantickitti_scans_range_image_carries_its_label_files_ids(geometry, tmp_path):
    from tests.helpers.dataset_helpers import read_kitti_labels, read_kitti_scan

    done = _scan(
        geometry, tmp_path / "scan.bin", "--format", "semantickitti", "--range-image", str(tmp_path / "i.npz")
    )
    assert done.returncode == 0, done.stderr
    xyz, remission = read_kitti_scan(tmp_path / "scan.bin")
    label, instance = read_kitti_labels(tmp_path / "scan.label")
    with np.load(tmp_path / "i.npz") as image:
        cell = image["row"], image["column"]
        assert len(cell[0]) == len(xyz)
        np.testing.assert_array_equal(image["intensity"][cell], remission)
        np.testing.assert_array_equal(image["label"][cell], label)
        np.testing.assert_array_equal(image["instance"][cell], instance)


# --------------------------------------------------------------------------- a multi-beam device plugs in

# A VLP-16-like device as a sensor file: its 16 lasers in firing order (laser ids 0..15) at -15,
# 1, -13, 3, ... 15 deg (the `vert_correction` of velodyne_pointcloud/params/VLP16db.yaml,
# github.com/ros-drivers/velodyne), a laser every 2.304 us in a 55.296 us firing cycle and 0.2 deg
# a firing at 10 Hz (Velodyne VLP-16 User Manual, firing timing), on a mount turning 360 deg.
# Its ranges, noise and optics are the test's own (the devices branch ships the real preset).
VLP16_LIKE = """
id = "vlp16-like"
vendor = "Test"
model = "VLP-16-like"
[beams]
kind = "table"
elevation_deg = [-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15]
azimuth_offset_deg = [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
[timing]
column_period_s = 0.000055296
steps_per_column = 24
beam_step = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]
[range]
min_m = 0.5
max_m = 30.0
max_dark_m = 100.0
[noise]
sigma_m = 0.01
accuracy = [[100.0, 0.03]]
accuracy_sigmas = 1.0
[optics]
divergence_mrad = 3.0
echoes = 2
echo_separation_m = 0.3
[mount]
kind = "rotating"
axis = [0.0, 0.0, 1.0]
tilt_deg = 0.0
step_deg = 0.2
min_step_deg = 0.1
sweep_deg = 360.0
"""


def test_a_multi_beam_devices_rows_are_its_rings_from_the_lowest_elevation():
    from wildscan.core.io.projection import kept_share, projection_for
    from wildscan.core.sensors.load import device_from_text

    device = device_from_text(VLP16_LIKE)
    sensor = SensorConfig.for_device(device, noise_sigma=0.0)
    result = run_scan(weather_scene(), Pose(0.0, 0.0, 0.0), sensor, "sensor")
    image = _image(result)
    assert image["range"].shape == (16, 1800)  # 16 rings by 360 / 0.2 firings
    n, m = np.nonzero(image["mask"])
    xyz = result.cloud.xyz[image["index"][n, m]]
    elevation = np.degrees(np.arcsin(xyz[:, 2] / np.linalg.norm(xyz, axis=1)))
    np.testing.assert_allclose(elevation, -15.0 + 2.0 * n, atol=1e-4)  # row r: the r-th lowest beam
    azimuth = np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0])) % 360.0
    np.testing.assert_allclose(
        np.minimum(np.abs(azimuth - 0.2 * m), 360 - np.abs(azimuth - 0.2 * m)), 0, atol=1e-4
    )
    # the semantic-kitti-api projection chosen for it keeps its points
    assert kept_share(result.cloud.xyz.astype(np.float32), projection_for(device, 0.2, "sensor")) >= 0.99
