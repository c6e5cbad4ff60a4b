"""Scanning with every device (core/sensors presets, device files, a rotating head): rings,
columns and times per point, both physics models in every frame, the files read back by
plyfile, laspy and rosbags, and the default device's bytes unchanged."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from wildscan.core.errors import UserError
from wildscan.core.placement import Pose
from wildscan.core.scan import run_scan
from wildscan.core.sensors import DEFAULT_DEVICE, SensorConfig, device_named, load_device, preset_names
from wildscan.core.sensors.load import PRESETS_DIR, device_from_text
from wildscan.core.spatial.frames import FRAMES

from tests.helpers.analytic import AnalyticBackend, Patch
from tests.helpers.scene_helpers import PAPER, WILDSCAN, user_error_line
from tests.test_formats import PARK_POSE_SEED_2_LOW
from tests.test_formats import geometry as seed_2_low_geometry

geometry = seed_2_low_geometry  # the fixture: seed 2 at low detail as a geometry file

EXAMPLES = PRESETS_DIR.parent / "examples"
HEAD_EXAMPLE = EXAMPLES / "vlp16-tilted-head.toml"
TIMEOUT_S = 300
MULTI_BEAM = ("vlp16", "hdl32e", "hdl64e", "os1-64", "vlp32c", "vls128", "os1-128")
HEADED = ("wildscenes",)  # presets on a turning head (a [head] table)


def wildscan(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([WILDSCAN, *args], capture_output=True, text=True, timeout=TIMEOUT_S)


def flat_ground() -> AnalyticBackend:
    return AnalyticBackend([Patch((0, 0, 0), (0, 0, 1), 1)])


def elevation_deg(xyz: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1])))


def four_beam_text() -> str:
    """A user's device file: the VLP-16's file cut to four beams."""
    text = (PRESETS_DIR / "vlp16.toml").read_text(encoding="utf-8")
    data_lines = []
    for line in text.splitlines():
        if line.startswith("elevation_deg"):
            line = "elevation_deg = [-10.0, 2.0, -4.0, 8.0]"
        elif line.startswith("azimuth_offset_deg"):
            line = "azimuth_offset_deg = [0.0, 0.0, 0.0, 0.0]"
        elif line.startswith("beam_step"):
            line = "beam_step = [0, 1, 2, 3]"
        elif line.startswith("id = "):
            line = 'id = "four"'
        data_lines.append(line)
    return "\n".join(data_lines) + "\n"


# --------------------------------------------------------------------------- the presets


def test_the_presets_are_listed_with_their_published_tables():
    assert set(preset_names()) >= {"utm30lx-ew", *MULTI_BEAM}
    vlp = device_named("vlp16")
    assert vlp.beams.count == 16 and vlp.timing.column_period_ns == 55_296
    assert vlp.timing.step_interval_s == pytest.approx(2.304e-6, abs=1e-15)
    # ring 0 is the lowest elevation, as the Velodyne driver numbers them
    assert [vlp.beams.elevation_deg[vlp.beams.ring.index(r)] for r in range(16)] == pytest.approx(
        [-15.0 + 2 * r for r in range(16)], abs=1e-12
    )
    hdl32 = device_named("hdl32e")
    assert sorted(hdl32.beams.elevation_deg) == pytest.approx(
        [-30.67 + 1.3333 * i for i in range(32)], abs=0.01
    )
    hdl64 = device_named("hdl64e")  # the S3 calibration file: non-uniform, with azimuth offsets
    steps = np.diff(np.sort(hdl64.beams.elevation_deg))
    assert hdl64.beams.count == 64 and steps.max() > 2 * steps.min() and not hdl64.beams.planar
    os1 = device_named("os1-64")
    assert os1.beams.count == 64 and os1.beams.ring[0] == 63  # beam 0 is Ouster's highest
    assert SensorConfig.for_device(os1).sweeps == 1024


def test_the_real_rigs_presets_carry_their_calibration_tables():
    """vlp32c and vls128 from ros-drivers/velodyne's VeloView-VLP-32C.yaml and VLS128.yaml, os1-128
    from an OS-1-128's published metadata (ouster-sdk tests/metadata), as their files cite."""
    vlp32 = device_named("vlp32c")  # the Ultra Puck: -25 to +15 deg, dense about the horizon
    assert vlp32.beams.count == 32 and vlp32.vertical_fov_deg == (-25.0, 15.0)
    assert vlp32.beams.elevation_deg[0] == -25.0 and vlp32.beams.azimuth_offset_deg[1] == pytest.approx(4.2)
    steps = np.diff(np.sort(vlp32.beams.elevation_deg))  # 0.33 deg apart at the finest (datasheet)
    assert steps.min() == pytest.approx(0.333, abs=1e-3) and steps.max() > 5.0
    assert vlp32.timing.column_period_ns == 55_296 and vlp32.timing.beam_step[:4] == (0, 0, 1, 1)
    vls = device_named("vls128")  # 16 groups of 8 in a 53.3 us sequence, a maintenance step after 8
    assert vls.beams.count == 128 and vls.timing.column_period_ns == 53_300
    assert vls.timing.steps_per_column == 20 and vls.timing.beam_step[63:65] == (7, 9)
    assert vls.beams.elevation_deg[36] == -25.0 and vls.beams.elevation_deg[59] == 15.0
    os128 = device_named("os1-128")
    assert os128.beams.count == 128 and os128.beams.ring[0] == 127  # beam 0 is Ouster's highest
    assert os128.vertical_fov_deg == pytest.approx((-21.4764, 21.4764))
    assert os128.beams.azimuth_offset_deg[0] == -4.2521  # -beam_azimuth_angles[0]
    assert SensorConfig.for_device(os128).sweeps == 1024


def test_the_wildscenes_rig_is_a_vlp16_tilted_45_deg_on_a_half_hz_head():
    """A VLP-16 (its own beams and timing) tilted 45 deg, turned 18 deg per 10 Hz revolution (0.5 Hz)
    through half a turn: its beams reach 120 deg of elevation, -60 to +60."""
    from wildscan.core.sensors import beam_directions

    ws, vlp = device_named("wildscenes"), device_named("vlp16")
    assert ws.beams == vlp.beams and ws.timing == vlp.timing and ws.mount == vlp.mount
    assert ws.head.tilt_deg == 45.0 and ws.head.turn == "continuous"
    assert ws.head.step_deg / vlp.sweep_period_s == pytest.approx(180.0, rel=0.01)  # 0.5 Hz: 180 deg/s
    dirs = beam_directions(ws.mount.step_deg, ws)[0]
    elevation = elevation_deg(dirs)
    assert elevation.min() == pytest.approx(-60.0) and elevation.max() == pytest.approx(60.0)


@pytest.mark.parametrize("name", MULTI_BEAM)
def test_spinning_lidars_turn_clockwise_as_their_drivers_count_azimuth(name):
    """Velodyne's driver and Ouster's encoder count azimuth clockwise seen from above: column
    m of beam i points at -m * step + its offset (counter-clockwise degrees)."""
    from wildscan.core.sensors import beam_directions

    device = device_named(name)
    step = device.mount.step_deg
    dirs, ring, column = beam_directions(step, device)
    azimuth = np.degrees(np.arctan2(dirs[:, 1], dirs[:, 0]))
    n = device.beams.count
    offsets = np.tile(np.asarray(device.beams.azimuth_offset_deg), len(dirs) // n)
    want = (-column.astype(np.float64) * step + offsets + 180.0) % 360.0 - 180.0
    assert np.abs((azimuth - want + 180.0) % 360.0 - 180.0).max() < 1e-9
    assert device_named("utm30lx-ew").mount.direction == "ccw"  # Eq. 1: the head turns by +r_h


def test_wildscan_sensors_lists_every_preset_with_its_source():
    done = wildscan("sensors")
    assert done.returncode == 0, done.stderr
    for name in preset_names():
        assert name in done.stdout
    assert "64e_s3-xiesc.yaml" in done.stdout and "2_0_0_os1-991913000010-64.json" in done.stdout
    assert {"vlp32c", "vls128", "os1-128", "wildscenes"} <= set(preset_names())
    line = next(x for x in done.stdout.splitlines() if x.startswith("wildscenes "))
    assert "tilted 45 deg on a head turning 180 deg: elevations -60.00 to +60.00 deg" in line


# --------------------------------------------------------------------------- every device, model, frame


@pytest.mark.parametrize("name", MULTI_BEAM + HEADED)
@pytest.mark.parametrize("model", ("paper", "realistic"))
def test_every_device_scans_flat_ground_in_every_frame(name, model):
    """Without noise a point on the ground is on the ground (world frame), and the leveled
    and sensor frames hold the same points (the frames' contract, docs/sensors.md)."""
    sensor = SensorConfig.for_device(device_named(name), model=model, noise_sigma=0.0)
    clouds = {
        frame: run_scan(flat_ground(), Pose(1.0, -2.0, 30.0), sensor, frame=frame).cloud for frame in FRAMES
    }
    world = clouds["world"]
    # the realistic model flags grazing footprints on no single surface (mixed); the rest are exact
    exact = world.extra["mixed"] == 0 if model == "realistic" else np.ones(len(world), bool)
    # (a realistic echo's range is float32 like every point's, a paper point's the exact product)
    assert exact.mean() > 0.5 and np.abs(world.xyz[exact, 2]).max() < (1e-3 if model == "realistic" else 1e-9)
    for frame in FRAMES:
        cloud = clouds[frame]
        assert len(cloud) == len(world) and np.array_equal(cloud.ring, world.ring)
        if frame != "world":  # the optical centre is the origin: a point is its range away
            assert np.linalg.norm(cloud.xyz, axis=1) == pytest.approx(cloud.range, abs=1e-4)
    assert set(np.unique(world.ring)) <= set(range(sensor.device.beams.count))


def test_a_tilted_rotating_head_is_a_sensor_file():
    device = load_device(HEAD_EXAMPLE)
    assert device.head is not None and device.head.steps == 45 and device.head.tilt_deg == 90.0
    sensor = SensorConfig.for_device(device, noise_sigma=0.0)
    assert sensor.sweeps == 45 * 1800 and sensor.beam_count == 45 * 1800 * 16
    result = run_scan(flat_ground(), Pose(0.0, 0.0, 0.0), sensor, frame="world")
    cloud = result.cloud
    assert np.abs(cloud.xyz[:, 2]).max() < 1e-9  # every point on the ground: the geometry is right
    # the spin axis lies horizontal: a revolution's beams reach the ground on both sides
    column = cloud.extra["column"]
    assert column.max() >= 44 * 1800 and np.all(cloud.sweep == column % 1800)
    # time runs on over the head's revolutions, one firing cycle a column
    period = device.timing.column_period_s
    assert np.all(np.abs(cloud.extra["time"] - column * period) < period)


def test_a_fixed_fan_on_a_head_is_the_rotating_utm30lx_ew_of_eq_1():
    """The paper's sensor written the other way round: the 2D scanner fixed, a [head] turning it
    1 deg a 2D scan through 180 deg. Same beams as Eq. 1 (to rounding), same rings and times."""
    from wildscan.core.sensors import beam_directions
    from wildscan.core.sensors.beams import beam_times

    text = (
        (PRESETS_DIR / "utm30lx-ew.toml")
        .read_text(encoding="utf-8")
        .replace('kind = "rotating"', 'kind = "fixed"')
    )
    text += "\n[head]\naxis = [0.0, 0.0, 1.0]\ntilt_deg = 0.0\nstep_deg = 1.0\nsweep_deg = 180.0\n"
    text += 'turn = "stepped"\n'
    headed = device_from_text(text, "fan-on-head.toml")
    a, ring_a, _ = beam_directions(1.0, DEFAULT_DEVICE)
    b, ring_b, _ = beam_directions(1.0, headed)
    assert a.shape == b.shape and np.abs(a - b).max() < 1e-15 and np.array_equal(ring_a, ring_b)
    assert np.array_equal(beam_times(1.0, DEFAULT_DEVICE), beam_times(1.0, headed))


def test_a_head_stepped_or_continuous_changes_only_where_the_beams_point():
    text = HEAD_EXAMPLE.read_text(encoding="utf-8")
    stepped = device_from_text(text.replace('turn = "continuous"', 'turn = "stepped"'), "stepped.toml")
    continuous = load_device(HEAD_EXAMPLE)
    from wildscan.core.sensors import beam_directions

    a, ring_a, sweep_a = beam_directions(0.2, stepped)
    b, ring_b, sweep_b = beam_directions(0.2, continuous)
    assert np.array_equal(ring_a, ring_b) and np.array_equal(sweep_a, sweep_b)
    n = 1800 * 16
    assert np.array_equal(a[0], b[0])  # the very first beam: the head has not turned yet
    turn = np.degrees(np.arccos(np.clip(np.sum(a[n - 16 : n] * b[n - 16 : n], axis=1), -1, 1)))
    assert turn.max() == pytest.approx(4.0, abs=0.05)  # by the end of a revolution: one head step


# --------------------------------------------------------------------------- through the command line


def scan(geometry, out: Path, *extra: str) -> subprocess.CompletedProcess:
    args = ("--pose", *PARK_POSE_SEED_2_LOW, "--quiet", "--out", str(out))
    done = wildscan("scan", "--geometry", str(geometry), *args, *extra)
    assert done.returncode == 0, done.stderr
    return done


def check_vlp16_scan(path: Path) -> None:
    """16 rings at -15..+15 deg every 2 deg within 0.01 deg, about 1,800 columns a
    revolution, every time within one revolution."""
    import plyfile

    v = plyfile.PlyData.read(str(path))["vertex"].data
    xyz = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)
    assert sorted(np.unique(v["ring"])) == list(range(16))
    elevation = elevation_deg(xyz)
    for ring in range(16):
        assert np.abs(elevation[v["ring"] == ring] - (-15.0 + 2 * ring)).max() < 0.01
    columns = np.unique(v["column"])
    assert 1700 <= len(columns) <= 1800 and columns.max() <= 1799
    assert v["time"].min() >= 0 and v["time"].max() < 0.1  # 10 Hz
    assert np.all(v["sweep"] == v["column"])  # no head: one revolution


def test_vlp16_scan_has_its_rings_columns_and_times(geometry, tmp_path):
    out = tmp_path / "vlp16.ply"
    scan(geometry, out, "--sensor", "vlp16", "--frame", "sensor", "--noise", "0")
    check_vlp16_scan(out)


@pytest.mark.slow
def test_vlp16_scan_of_seed_1_as_the_issue_states(tmp_path):
    out = tmp_path / "vlp16.ply"
    pose = ("31.712", "65.125", "236.7")  # the forest's first valid pose (tests/golden/scans.json)
    done = wildscan("scan", *PAPER, "--seed", "1", "--pose", *pose, "--sensor", "vlp16", "--frame", "sensor")
    assert done.returncode == 2  # --out is required: nothing to scan into
    done = wildscan(
        "scan", *PAPER, "--seed", "1", "--pose", *pose, "--sensor", "vlp16", "--frame", "sensor",
        "--noise", "0", "--quiet", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    check_vlp16_scan(out)


def test_a_wildscenes_scan_spans_more_than_110_deg_of_elevation():
    """The issue's bar: under a canopy the tilted VLP-16 on its turning mount sees the ground and
    the crowns overhead alike (the VLP-16 alone spans 30 deg)."""
    terrain, treetop = 1, 3
    forest = AnalyticBackend([Patch((0, 0, 0), (0, 0, 1), terrain), Patch((0, 0, 6), (0, 0, -1), treetop, 2)])
    sensor = SensorConfig.for_device(device_named("wildscenes"), noise_sigma=0.0)
    cloud = run_scan(forest, Pose(0.0, 0.0, 0.0), sensor, frame="leveled").cloud
    elevation = elevation_deg(cloud.xyz)
    assert elevation.max() - elevation.min() >= 110.0
    assert set(np.unique(cloud.ring)) == set(range(16))
    assert set(np.unique(cloud.label)) == {terrain, treetop}


def test_a_4_beam_sensor_file_gives_4_rings(geometry, tmp_path):
    device = tmp_path / "four.toml"
    device.write_text(four_beam_text(), encoding="utf-8")
    out = tmp_path / "four.ply"
    scan(geometry, out, "--sensor", str(device), "--frame", "sensor", "--noise", "0")
    import plyfile

    v = plyfile.PlyData.read(str(out))["vertex"].data
    assert sorted(np.unique(v["ring"])) == [0, 1, 2, 3]
    elevation = elevation_deg(np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64))
    for ring, want in enumerate((-10.0, -4.0, 2.0, 8.0)):
        assert np.abs(elevation[v["ring"] == ring] - want).max() < 0.01


def test_the_default_device_named_writes_todays_bytes(geometry, tmp_path):
    scan(geometry, tmp_path / "a.ply", "--rh", "4")
    scan(geometry, tmp_path / "b.ply", "--rh", "4", "--sensor", "utm30lx-ew")
    assert (tmp_path / "a.ply").read_bytes() == (tmp_path / "b.ply").read_bytes()
    import plyfile

    names = plyfile.PlyData.read(str(tmp_path / "a.ply"))["vertex"].data.dtype.names
    assert "column" not in names and "time" not in names  # the default's files keep their fields


def test_las_carries_column_and_time_as_extra_dimensions(geometry, tmp_path):
    import laspy

    out = tmp_path / "os1.las"
    scan(geometry, out, "--sensor", "os1-64", "--format", "las", "--frame", "world")
    las = laspy.read(out)
    assert {"ring", "sweep", "column", "time"} <= set(las.point_format.extra_dimension_names)
    assert sorted(np.unique(las.ring)) == list(range(64)) or len(np.unique(las.ring)) > 50
    assert np.array_equal(np.asarray(las.column), np.asarray(las.sweep))
    assert np.allclose(np.asarray(las.time), np.asarray(las.column) * 97.656e-6, atol=1e-12)
    assert np.array_equal(np.asarray(las.gps_time), np.asarray(las.time))


BAD_FILES = [
    ("count", 'kind = "table"', 'kind = "cone"', 'beams.kind must be one of "fan", "table", got "cone"'),
    (
        "steps",
        "beam_step = [0, 1, 2, 3]",
        "beam_step = [0, 1, 2, 99]",
        "timing.beam_step must be a list of 4 whole numbers from 0 to 23",
    ),
    (
        "unknown",
        "sigma_m = 0.015",
        "sigma_m = 0.015\nsigma = 2",
        "unknown key 'noise.sigma'; allowed in [noise]",
    ),
]


@pytest.mark.parametrize("case, old, new, says", BAD_FILES, ids=[c[0] for c in BAD_FILES])
def test_a_bad_sensor_file_exits_2_naming_the_key_and_writes_nothing(
    geometry, tmp_path, case, old, new, says
):
    text = four_beam_text()
    assert old in text
    device = tmp_path / "bad.toml"
    device.write_text(text.replace(old, new, 1), encoding="utf-8")
    out = tmp_path / "scan.ply"
    done = wildscan(
        "scan",
        "--geometry",
        str(geometry),
        "--pose",
        *PARK_POSE_SEED_2_LOW,
        "--sensor",
        str(device),
        "--out",
        str(out),
    )
    assert done.returncode == 2
    line = user_error_line(done)
    assert line.startswith("wildscan scan: ") and "bad.toml: " in line and says in line
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_an_unknown_preset_and_a_bad_head_step_are_user_errors(tmp_path):
    done = wildscan(
        "scan", "--seed", "1", "--pose", "0", "0", "0", "--sensor", "vlp99", "--out", str(tmp_path / "s.ply")
    )
    assert done.returncode == 2
    line = user_error_line(done)
    assert "--sensor must be one of" in line and "vlp16" in line and "'vlp99'" in line
    text = HEAD_EXAMPLE.read_text(encoding="utf-8").replace("step_deg = 4.0", "step_deg = 7.0")
    with pytest.raises(UserError, match=r"head.step_deg must be a step dividing sweep_deg 180 .* got 7.0"):
        device_from_text(text, "head.toml")


# --------------------------------------------------------------------------- a drive's bag


@pytest.mark.slow
def test_drive_with_vlp16_publishes_ring_and_time_that_rosbags_reads(tmp_path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    out = tmp_path / "drive"
    done = wildscan(
        "drive", "--seed", "1", "--from", "31.712", "65.125", "236.7", "--distance", "0.1",
        "--sensor", "vlp16", "--mount-height", "1.5", "--bag", "ros2", "--quiet", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Reader(out / "drive_ros2") as reader:
        points = [c for c in reader.connections if c.topic == "/points"]
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts["/laser2D"] == 0  # a multi-beam lidar's columns are no LaserScans
        connection, _, raw = next(reader.messages(connections=points))
        message = store.deserialize_cdr(raw, connection.msgtype)
        static = [c for c in reader.connections if c.topic == "/tf_static"]
        tf_connection, _, tf_raw = next(reader.messages(connections=static))
        statics = store.deserialize_cdr(tf_raw, tf_connection.msgtype).transforms
    (mast,) = [tf for tf in statics if tf.child_frame_id == "sensor"]
    assert mast.header.frame_id == "base_link" and mast.transform.translation.z == 1.5  # --mount-height
    fields = {f.name: (f.offset, f.datatype) for f in message.fields}
    assert fields["ring"][1] == 4 and fields["time"][1] == 7  # UINT16 and FLOAT32, as the Velodyne driver
    records = np.frombuffer(
        message.data,
        dtype=np.dtype(
            {"names": ["ring", "time"], "formats": ["<u2", "<f4"],
             "offsets": [fields["ring"][0], fields["time"][0]], "itemsize": message.point_step}
        ),
    )  # fmt: skip
    assert sorted(np.unique(records["ring"])) == list(range(16))
    assert 0 <= records["time"].min() and records["time"].max() < 0.1


# --------------------------------------------------------------------------- speed (no timing here)


def test_a_frame_is_cast_in_one_batch_call():
    """All beams of an os1-64 or hdl64e frame go to the caster in one call (the speed goal
    lives in `wildscan bench`)."""
    for name in ("os1-64", "hdl64e"):
        backend = flat_ground()
        calls = []
        cast = backend.cast

        def counting(origins, dirs, max_range, normals=False, cast=cast, calls=calls):
            calls.append(len(dirs))
            return cast(origins, dirs, max_range, normals)

        backend.cast = counting
        sensor = SensorConfig.for_device(device_named(name))
        run_scan(backend, Pose(0.0, 0.0, 0.0), sensor)
        placement_probes = calls[:-1]
        assert calls[-1] == sensor.beam_count and all(n < 10 for n in placement_probes), calls


def test_the_default_device_is_the_utm30lx_ew_and_its_fields_are_as_before():
    sensor = SensorConfig()
    assert sensor.device is DEFAULT_DEVICE and "device" not in sensor.to_dict()
    result = run_scan(flat_ground(), Pose(0.0, 0.0, 0.0), SensorConfig(rh_deg=4.0, noise_sigma=0.0))
    assert result.cloud.extra == {}
    # its nearest ground point is at the blind cone's edge: 45 deg off straight down
    assert math.isclose(result.cloud.range.min(), 0.723 / math.cos(math.radians(45)), rel_tol=1e-6)


# --------------------------------------------------------------------------- a dataset spec's device


def test_a_spec_device_list_is_drawn_per_scan_with_each_devices_own_settings():
    from wildscan.app.dataset.card import _device_words
    from wildscan.app.dataset.draws import draw_sensor
    from wildscan.app.dataset.spec import DatasetSpec, spec_from_dict, spec_from_json

    assert "device" not in DatasetSpec().to_dict()["sensor"]  # the default keeps its config hash
    assert _device_words(DatasetSpec()) == ""  # and its card's words
    spec = spec_from_dict({"sensor": {"device": ["vlp16", "os1-64"], "max_range": [50.0, 80.0]}})
    assert spec.sensor.device == ("vlp16", "os1-64") and spec.sensor.rh is None
    assert _device_words(spec) == ", device vlp16 / os1-64"
    assert spec_from_json(spec.to_dict()) == spec  # as workers receive it
    drawn = {draw_sensor(spec.sensor, 1, index).device.id for index in range(12)}
    assert drawn == {"vlp16", "os1-64"}
    for index in range(4):
        sensor = draw_sensor(spec.sensor, 1, index)
        assert sensor.rh_deg == sensor.device.mount.step_deg and 50.0 <= sensor.max_range <= 80.0
        assert sensor == draw_sensor(spec.sensor, 1, index)  # the same draw every time


@pytest.mark.parametrize(
    "sensor, says",
    [
        (
            {"device": "vlp99"},
            "sensor.device must be one of hdl32e, hdl64e, os1-128, os1-64, utm30lx-ew, vlp16, vlp32c, "
            "vls128, wildscenes",
        ),
        ({"device": "vlp16", "max_range": 150.0}, "with device vlp16, sensor.max_range must be in (0, 100]"),
        ({"device": "vlp16", "rh": [0.1, 0.2]}, "sensor.rh must be a number"),
    ],
)
def test_a_bad_spec_device_names_the_key(sensor, says):
    from wildscan.app.dataset.spec import spec_from_dict

    with pytest.raises(UserError) as info:
        spec_from_dict({"sensor": sensor})
    assert says in str(info.value) and str(info.value).startswith("SPEC.toml: ")
