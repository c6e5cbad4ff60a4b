"""A dataset's range images (rangeimage/NNNNNN.npz beside each .bin) and the projection its
labels.yaml ships, read back with semantic-kitti-api's own LaserScan/SemLaserScan
(tests/helpers/semantic_kitti_laserscan.py) and numpy by SemanticKITTI's published layout."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from wildscan.core.io.projection import Projection, combined, kept_share, projection_for
from wildscan.core.sensors import DEFAULT_DEVICE, beam_directions, device_named

from tests.helpers.dataset_helpers import (
    manifest_rows,
    read_kitti_labels,
    read_kitti_scan,
    wildscan,
    written_dataset,
)
from tests.helpers.semantic_kitti_laserscan import LaserScan, SemLaserScan

SPEC = """\
layout = "paper"
seeds = [1]
scans_per_world = 3
formats = ["semantickitti"]
label_scheme = "semantickitti"

[poses]
strategy = "zones"
zones = { forest = 1, park = 1, hills = 1 }

[sensor]
rh = [1.0, 2.0]  # a range: each scan draws 180/M in it
"""
FORMATS_MD = Path(__file__).resolve().parent.parent / "docs" / "formats.md"
KITTI_DEFAULT = dict(H=64, W=1024, fov_up=3.0, fov_down=-25.0)  # LaserScan's own defaults


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return written_dataset(tmp_path_factory.mktemp("rangeimage"), SPEC)[0]


def _scans(dataset):
    """(velodyne .bin, .label, rangeimage .npz) of every scan, by file number."""
    sequence = dataset / "sequences" / "00"
    bins = sorted((sequence / "velodyne").glob("*.bin"))
    assert [p.stem for p in bins] == ["000000", "000001", "000002"]
    return [
        (b, sequence / "labels" / f"{b.stem}.label", sequence / "rangeimage" / f"{b.stem}.npz") for b in bins
    ]


@pytest.mark.slow
def test_each_bin_has_its_range_image_numbered_as_it_is(dataset):
    images = sorted(p.name for p in (dataset / "sequences" / "00" / "rangeimage").iterdir())
    assert images == [f"{b.stem}.npz" for b, _, _ in _scans(dataset)]
    assert wildscan("dataset", "--verify", str(dataset)).returncode == 0  # listed in the manifest


@pytest.mark.slow
def test_each_bin_point_sits_in_its_range_image_cell(dataset):
    rh = [row["sensor"]["rh"] for row in manifest_rows(dataset)]
    for (bin_path, label_path, npz), scan_rh in zip(_scans(dataset), rh, strict=True):
        xyz, remission = read_kitti_scan(bin_path)
        label, instance = read_kitti_labels(label_path)
        with np.load(npz) as image:
            assert image["range"].shape == (1080, round(180 / scan_rh))  # beams n by 2D scans m
            cell = image["row"], image["column"]
            assert len(cell[0]) == len(xyz) == image["mask"].sum()  # one beam, one point (paper model)
            np.testing.assert_array_equal(image["index"][cell], np.arange(len(xyz)))
            # a leveled point is its range along its beam: the norm is the range
            np.testing.assert_allclose(image["range"][cell], np.linalg.norm(xyz, axis=1), rtol=1e-5)
            np.testing.assert_array_equal(image["intensity"][cell], remission)
            np.testing.assert_array_equal(image["label"][cell], label)
            np.testing.assert_array_equal(image["instance"][cell], instance)
            assert (image["range"][~image["mask"]] == -1).all()


def _projection(dataset) -> dict:
    config = yaml.safe_load((dataset / "labels.yaml").read_text())
    assert set(config["projection"]) == {"H", "W", "fov_up", "fov_down"}
    return config["projection"]


def _kept(scan: LaserScan) -> float:
    """The share of the scan's points that keep a pixel of their own in the projection."""
    return len(np.unique(scan.proj_idx[scan.proj_idx >= 0])) / len(scan.points)


@pytest.mark.slow
def test_labels_yaml_projection_keeps_99_percent_in_semantic_kitti_api(dataset):
    projection = _projection(dataset)
    config = yaml.safe_load((dataset / "labels.yaml").read_text())
    kept, kitti_kept = [], []
    for bin_path, label_path, _ in _scans(dataset):
        scan = SemLaserScan(config["color_map"], project=True, **projection)
        scan.open_scan(str(bin_path))
        scan.open_label(str(label_path))
        kept.append(_kept(scan))
        # the projected labels are the points' own
        held = scan.proj_idx >= 0
        np.testing.assert_array_equal(scan.proj_sem_label[held], scan.sem_label[scan.proj_idx[held]])
        default = LaserScan(project=True, **KITTI_DEFAULT)
        default.open_scan(str(bin_path))
        kitti_kept.append(_kept(default))
    assert min(kept) >= 0.99, kept
    assert max(kitti_kept) < 0.5, kitti_kept  # what the API's HDL-64E defaults would lose
    assert projection["W"] == 720  # the finest r_h the spec draws (1 deg), two pixels a step
    # the comment above the keys says what share of an untilted scan's beams it keeps
    said = re.search(
        r"^# semantic-kitti-api's .* keeps ([\d.]+) % of an untilted scan's beams\nprojection:",
        (dataset / "labels.yaml").read_text(),
        re.M,
    )
    assert said and float(said.group(1)) >= 99.5


@pytest.fixture(scope="module")
def os1_dataset(tmp_path_factory):
    """Two scans by an Ouster OS1-64 (64 rings by 1024 firings)."""
    root = tmp_path_factory.mktemp("os1")
    spec = SPEC.replace("rh = [1.0, 2.0]", 'device = "os1-64"').replace(
        "scans_per_world = 3", "scans_per_world = 2"
    )
    (root / "spec.toml").write_text(spec.replace("forest = 1, park = 1, hills = 1", "forest = 1, park = 1"))
    done = wildscan("dataset", str(root / "spec.toml"), "--out", str(root / "out"), "--workers", "1")
    assert done.returncode == 0, done.stderr
    return root / "out"


@pytest.mark.slow
def test_an_os1_64_dataset_loads_in_semlaserscan_keeping_its_points_and_rings(os1_dataset):
    projection = _projection(os1_dataset)
    config = yaml.safe_load((os1_dataset / "labels.yaml").read_text())
    sequence = os1_dataset / "sequences" / "00"
    for bin_path in sorted((sequence / "velodyne").glob("*.bin")):
        scan = SemLaserScan(config["color_map"], project=True, **projection)
        scan.open_scan(str(bin_path))
        scan.open_label(str(sequence / "labels" / f"{bin_path.stem}.label"))
        assert _kept(scan) >= 0.99
        with np.load(sequence / "rangeimage" / f"{bin_path.stem}.npz") as image:
            assert image["range"].shape == (64, 1024)  # its rings by its firings
            assert image["mask"].sum() == len(scan.points)
            np.testing.assert_array_equal(image["label"][image["row"], image["column"]], scan.sem_label)


# --------------------------------------------------------------------------- docs/formats.md


def _doc_table(heading: str) -> list[list[str]]:
    """The body rows of the first table under `heading` in docs/formats.md, cell by cell."""
    section = FORMATS_MD.read_text(encoding="utf-8").split(heading, 1)[1]
    lines = re.search(r"((?:^\|.*\n)+)", section, re.M).group(1).splitlines()
    return [[c.strip().strip("`") for c in line.strip().strip("|").split("|")] for line in lines[2:]]


@pytest.mark.slow
def test_the_range_image_arrays_are_the_ones_formats_md_describes(dataset):
    rows = _doc_table("## Range images")
    # this dataset is the paper model's: the arrays of the realistic model alone are not in it
    documented = {
        name: (dtype, shape) for name, dtype, shape, what in rows if not what.startswith("realistic")
    }
    assert any(what.startswith("realistic model only") for *_, what in rows)  # `lost`
    bin_path, _, npz = _scans(dataset)[0]
    points = len(read_kitti_scan(bin_path)[0])
    with np.load(npz) as image:
        assert sorted(image.files) == sorted(documented)
        h, w = image["range"].shape
        for name, (dtype, shape) in documented.items():
            assert image[name].dtype == np.dtype(dtype), name
            assert image[name].shape == {"(H, W)": (h, w), "(N,)": (points,)}[shape], name


@pytest.mark.slow
def test_the_projection_keys_are_the_ones_formats_md_describes(dataset):
    documented = [row[0] for row in _doc_table("### Projection for semantic-kitti-api")]
    assert sorted(documented) == sorted(_projection(dataset))


# --------------------------------------------------------------------------- core/io/projection.py


def test_a_sensor_frame_scan_keeps_its_beams_where_the_kitti_default_loses_most():
    dirs = beam_directions(1.0)[0].astype(np.float32)
    p = projection_for(DEFAULT_DEVICE, 1.0, "sensor")
    assert kept_share(dirs, p) >= 0.995
    assert kept_share(dirs, Projection(**KITTI_DEFAULT)) < 0.25
    # the field of view is the scanner's: 45 deg below the horizon (the 90 deg blind cone) to the zenith
    pitch_cell = (p.fov_up - p.fov_down) / p.H
    assert p.fov_up == pytest.approx(90 + pitch_cell / 2)
    assert p.fov_down == pytest.approx(-45 - pitch_cell / 2)


def test_the_leveled_frame_makes_room_for_the_robots_tilt_and_the_world_frame_has_none():
    sensor, leveled = (projection_for(DEFAULT_DEVICE, 2.0, f) for f in ("sensor", "leveled"))
    assert leveled.fov_up == sensor.fov_up and leveled.fov_down == pytest.approx(sensor.fov_down - 25)
    assert projection_for(DEFAULT_DEVICE, 2.0, "world") is None


def test_several_settings_share_the_widest_view_at_the_finest_pixels():
    a, b = Projection(100, 360, 10.0, -10.0), Projection(60, 720, 20.0, -10.0)
    assert combined([a, b]) == Projection(150, 720, 20.0, -10.0)
    assert combined([]) is None


@pytest.mark.parametrize(
    "sensor, expected",
    [
        ({"rh": [0.5, 4.0]}, projection_for(DEFAULT_DEVICE, 0.5, "leveled")),  # the finest r_h drawn
        ({"rh": 2.0, "frame": "sensor"}, projection_for(DEFAULT_DEVICE, 2.0, "sensor")),
        ({"frame": "world"}, None),  # points around the world's origin: no projection fits them
        ({"device": "vlp16", "frame": "sensor"}, projection_for(device_named("vlp16"), 0.2, "sensor")),
        (  # every device the spec may draw: the widest view at the finest pixels of any
            {"device": ["os1-64", "vlp16"]},
            combined(
                [
                    projection_for(device_named(d), device_named(d).mount.step_deg, "leveled")
                    for d in ("os1-64", "vlp16")
                ]
            ),
        ),
    ],
)
def test_a_datasets_projection_fits_every_scan_its_spec_may_draw(sensor, expected):
    from wildscan.app.dataset.projection import dataset_projection
    from wildscan.app.dataset.spec import spec_from_dict

    spec = spec_from_dict({"seeds": [1], "scans_per_world": 1, "sensor": sensor})
    assert dataset_projection(spec) == expected
