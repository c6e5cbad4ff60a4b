"""`wildscan drive` outputs: ROS bags read back by rosbags (ROS 2) and Debian's python3-rosbag
(ROS 1), SemanticKITTI, determinism, user mistakes, interrupts, wind."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from wildscan.app.drive import DriveRequest, Interrupted, run_drive
from wildscan.app.drive import bags as bag_module
from wildscan.app.interrupts import Terminated
from wildscan.core.io.imu_csv import read_imu_csv
from wildscan.core.io.ply import read_ply
from wildscan.core.sensor import SensorConfig

from tests.helpers.processes import started
from tests.helpers.scene_helpers import WILDSCAN, run, user_error_line

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

SEED = 1
RH = 6.0  # 30 2D scans a 3D scan
COMMON = ["--seed", str(SEED), "--detail", "low", "--rh", str(RH), "--trail"]
TOPICS = {"/tf_static": 1, "/tf": 66, "/odom": 66, "/laser2D": 66, "/points": 2, "/points_deskewed": 2}
TOPICS["/imu"] = 330  # 1.65 s at 200 Hz


@pytest.fixture(scope="module")
def drive_dir(tmp_path_factory):
    """Two 3D scans and 6 more 2D scans along the trail of seed 1, both bags."""
    out = tmp_path_factory.mktemp("drive")
    request = DriveRequest(
        out=str(out),
        seed=SEED,
        detail="low",
        trail=True,
        sensor=SensorConfig(rh_deg=RH),
        speed=1.0,
        scans=None,
    )
    request = _limited(request, out)
    report = run_drive(request, say=lambda text: None)
    assert (report.scans_2d, report.scans_3d) == (66, 2)
    return out


def _limited(request: DriveRequest, out):
    """The trail's first 1.65 m as waypoints: 66 2D scans at 1 m/s."""
    from wildscan.bench.drive import trail_waypoints

    csv = out.parent / f"{out.name}.csv"
    csv.write_text("".join(f"{x!r},{y!r}\n" for x, y in trail_waypoints(SEED, 66 * 0.025)))
    from dataclasses import replace

    return replace(request, trail=False, waypoints=str(csv))


def test_ros2_bag_reads_back_with_rosbags(drive_dir):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    raw, _ = read_ply(drive_dir / "raw" / "000001.ply")
    counts: dict[str, int] = {}
    with AnyReader([drive_dir / "drive_ros2"], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types["/laser2D"] == "sensor_msgs/msg/LaserScan"
        assert types["/points"] == "sensor_msgs/msg/PointCloud2"
        assert types["/tf"] == "tf2_msgs/msg/TFMessage" and types["/odom"] == "nav_msgs/msg/Odometry"
        assert types["/imu"] == "sensor_msgs/msg/Imu"
        last, imu, stamps = {}, [], []
        for conn, stamp, data in reader.messages():
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
            stamps.append(stamp)
            msg = reader.deserialize(data, conn.msgtype)
            if conn.topic == "/imu":
                assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == stamp
                imu.append((stamp, msg.angular_velocity.z, msg.linear_acceleration.z, msg.orientation.w))
            if conn.topic == "/laser2D":
                k = counts["/laser2D"] - 1
                assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == k * 25_000_000 == stamp
                assert len(msg.ranges) == len(msg.intensities) == 1080 and msg.header.frame_id == "laser"
                assert (
                    abs(msg.angle_min + np.radians(135)) < 1e-6
                    and abs(msg.time_increment - 0.025 / 1440) < 1e-9
                )
            last[conn.topic] = msg
    assert counts == TOPICS
    cloud = last["/points"]
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "intensity", "ring", "time", "label", "instance"]
    assert cloud.width == len(raw) and cloud.point_step == 32 and cloud.header.frame_id == "sensor"
    assert cloud.header.stamp.sec * 10**9 + cloud.header.stamp.nanosec == 30 * 25_000_000
    from wildscan.core.io.rosbag import POINT_DTYPE

    points = np.frombuffer(bytes(cloud.data), dtype=POINT_DTYPE)
    assert np.array_equal(points["label"], raw["label"]) and np.array_equal(points["ring"], raw["ring"])
    assert np.allclose(points["x"], raw["x"]) and np.allclose(points["time"], raw["time"])
    tf = last["/tf"].transforms
    assert [(t.header.frame_id, t.child_frame_id) for t in tf] == [
        ("odom", "base_link"),
        ("base_link", "laser"),
    ]
    assert last["/odom"].child_frame_id == "base_link" and 0.9 < last["/odom"].twist.twist.linear.x < 1.1
    assert stamps == sorted(stamps)  # every topic in time order, the IMU's 200 Hz among them
    assert [s for s, *_ in imu] == [i * 5_000_000 for i in range(330)] and last[
        "/imu"
    ].header.frame_id == "imu"
    _, gyro, accel = read_imu_csv((drive_dir / "imu.csv").read_text())  # the same samples as the CSV
    assert np.allclose([g for _, g, _, _ in imu], gyro[:, 2], atol=1e-11)
    assert np.allclose([a for _, _, a, _ in imu], accel[:, 2], atol=1e-8)
    covariance = np.asarray(last["/imu"].angular_velocity_covariance).reshape(3, 3)
    assert np.isclose(covariance[0, 0], (np.radians(0.014) * np.sqrt(200)) ** 2)  # BMI088's white noise
    static = [(t.header.frame_id, t.child_frame_id) for t in last["/tf_static"].transforms]
    assert static == [("base_link", "sensor"), ("base_link", "imu")]


ROS1_READER = r"""
import json, sys, collections, rosbag
bag = rosbag.Bag(sys.argv[1])
counts = collections.Counter()
out = {}
for topic, msg, t in bag.read_messages():
    counts[topic] += 1
    if topic == "/laser2D":
        sizes = [len(msg.ranges), len(msg.intensities)]
        out["scan"] = [msg.header.frame_id] + sizes + [msg.angle_min, msg.scan_time]
    if topic == "/points":
        fields = [f.name for f in msg.fields]
        stamps = [msg.header.stamp.to_sec(), t.to_sec()]
        out["points"] = [msg.header.frame_id, msg.width, msg.point_step, fields] + stamps
    if topic == "/tf":
        out["tf"] = [[x.header.frame_id, x.child_frame_id] for x in msg.transforms]
    if topic == "/tf_static":
        out["static"] = [[x.header.frame_id, x.child_frame_id, x.transform.translation.z]
                         for x in msg.transforms]
    if topic == "/odom":
        out["odom"] = [msg.header.frame_id, msg.child_frame_id, msg.twist.twist.linear.x]
    if topic == "/imu":
        out["imu"] = [msg.header.frame_id, msg.header.stamp.to_sec(), msg.linear_acceleration.z,
                      msg.orientation.w, len(msg.angular_velocity_covariance)]
out["counts"] = dict(counts)
out["types"] = {k: v.msg_type for k, v in bag.get_type_and_topic_info().topics.items()}
print(json.dumps(out))
"""


@pytest.mark.external
def test_ros1_bag_reads_back_with_debians_rosbag(drive_dir):
    proc = subprocess.run(
        ["/usr/bin/python3", "-c", ROS1_READER, str(drive_dir / "drive.bag")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    assert got["counts"] == TOPICS
    assert got["types"]["/laser2D"] == "sensor_msgs/LaserScan" and got["types"]["/tf"] == "tf2_msgs/TFMessage"
    assert got["scan"][:3] == ["laser", 1080, 1080] and abs(got["scan"][4] - 0.025) < 1e-9
    frame, width, step, fields, stamp, recorded = got["points"]
    raw, _ = read_ply(drive_dir / "raw" / "000001.ply")
    assert (frame, width, step) == ("sensor", len(raw), 32)
    assert fields == ["x", "y", "z", "intensity", "ring", "time", "label", "instance"]
    assert (
        abs(stamp - 0.75) < 1e-9 and abs(recorded - 1.5) < 1e-9
    )  # stamped at its start, recorded at its end
    assert got["tf"] == [["odom", "base_link"], ["base_link", "laser"]]
    assert got["static"] == [["base_link", "sensor", 0.723], ["base_link", "imu", 0.35]]
    frame, stamp, accel_z, w, covariance = got["imu"]
    _, _, accel = read_imu_csv((drive_dir / "imu.csv").read_text())
    assert (
        (frame, covariance) == ("imu", 9) and abs(stamp - 1.645) < 1e-9 and abs(accel_z - accel[-1, 2]) < 1e-8
    )
    assert got["types"]["/imu"] == "sensor_msgs/Imu" and 0 < w <= 1
    assert got["odom"][:2] == ["odom", "base_link"]


def test_semantickitti_sequence_and_trajectory(drive_dir):
    seq = drive_dir / "sequences" / "00"
    poses = np.loadtxt(seq / "poses.txt").reshape(-1, 3, 4)
    assert len(poses) == 2 and np.loadtxt(seq / "times.txt").tolist() == [0.0, 0.75]
    desk, _ = read_ply(drive_dir / "deskewed" / "000001.ply")
    velodyne = np.fromfile(seq / "velodyne" / "000001.bin", dtype="<f4").reshape(-1, 4)
    labels = np.fromfile(seq / "labels" / "000001.label", dtype="<u4")
    assert len(velodyne) == len(labels) == len(desk)
    assert np.array_equal(velodyne[:, :3], np.column_stack([desk["x"], desk["y"], desk["z"]]))
    tum = np.loadtxt(drive_dir / "trajectory.tum")
    assert tum.shape == (66, 8) and np.allclose(np.linalg.norm(tum[:, 4:], axis=1), 1)
    assert np.allclose(poses[1][:, 3], tum[30, 1:4])  # sensor frame: the pose is the optical centre
    summary = json.loads((drive_dir / "drive.json").read_text())
    assert summary["scans_2d"] == 66 and summary["bags"]["ros1"]["/laser2D"] == 66
    assert sorted(summary["files"]) == sorted(
        str(p.relative_to(drive_dir)) for p in drive_dir.rglob("*") if p.is_file()
    )


def test_same_drive_same_bytes(tmp_path):
    def drive(out):
        proc = run(
            [WILDSCAN, "drive", *COMMON, "--scans", "1", "--noise", "0.02", "--quiet", "--out", str(out)]
        )
        assert proc.returncode == 0, proc.stderr
        return {p.relative_to(out): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}

    first, second = drive(tmp_path / "a"), drive(tmp_path / "b")
    assert first.keys() == second.keys() and len(first) > 10
    assert all(first[name] == second[name] for name in first), [n for n in first if first[n] != second[n]]


@pytest.mark.parametrize(
    "args, says",
    [
        (["--speed", "-1"], "--speed must be from 0"),
        (["--from", "0", "0", "0"], "--from X Y YAW and --distance M go together"),
        (["--waypoints", "{tmp}/bad.csv"], "line 3: expected `x,y`"),
        (["--waypoints", "{tmp}/missing.csv"], "no such file"),
        (["--from", "73", "-40", "0", "--distance", "20"], "the drive stops at t = "),
        (["--from", "0", "0", "0", "--distance", "0.5"], "shorter than one 3D scan"),
        (["--trail", "--scans", "500"], "--scans 500 3D scans at 1 m/s need"),
        (["--trail", "--rh", "7"], "--rh must divide 180"),
        (["--trail", "--wind", "45"], "--wind must be from 0"),
        (
            ["--trail", "--model", "realistic"],
            "--model must be paper: a drive emulates the paper sensor model",
        ),
        (["--trail", "--vegetation", "leafy"], "--vegetation must be one of"),
        (["--trail", "--imu-rate", "5000"], "--imu-rate: must be a whole number from 1 to 2000"),
        (
            ["--trail", "--imu", "xsens"],
            "--imu: invalid choice: 'xsens' (choose from 'bmi088', 'adis16495', 'none')",
        ),
    ],
)
def test_user_mistakes_exit_2_with_one_line(tmp_path, args, says):
    (tmp_path / "bad.csv").write_text("x,y\n0,0\n1;2\n")
    out = tmp_path / "out"
    base = ["--seed", str(SEED), "--detail", "low", "--rh", str(RH), "--quiet", "--out", str(out)]
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if not any(a in argv for a in ("--trail", "--waypoints", "--from")):
        argv = ["--trail", *argv]
    proc = run([WILDSCAN, "drive", *base, *argv])
    assert proc.returncode == 2, proc.stdout + proc.stderr
    line = user_error_line(proc)
    assert line.startswith("wildscan drive: error: ") and says in line, line
    assert not out.exists() or not any(out.iterdir())  # nothing written


def drive_cli(tmp_path, *args: str):
    """`wildscan drive ARGS --rh 10 --bag none --quiet --out TMP/d`, which must succeed."""
    proc = run(
        [WILDSCAN, "drive", *args, "--rh", "10", "--bag", "none", "--quiet", "--out", str(tmp_path / "d")]
    )
    assert proc.returncode == 0, proc.stderr
    return tmp_path / "d"


def test_trail_of_a_blend_without_one_is_a_user_mistake(tmp_path):
    blend = tmp_path / "plane.blend"
    script = (
        "import bpy\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "bpy.ops.mesh.primitive_plane_add(size=40)\n"
        "bpy.context.object['wildscan_class'] = 'terrain'\n"
        "bpy.context.object['wildscan_instance'] = 1\n"
        f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})\n"
    )
    assert run([str(WILDSCAN).replace("wildscan", "python"), "-c", script]).returncode == 0
    proc = run([WILDSCAN, "drive", "--world", str(blend), "--trail", "--out", str(tmp_path / "d")])
    assert proc.returncode == 2
    assert "--trail needs a WildScan world with a trail" in user_error_line(proc)
    out = drive_cli(
        tmp_path, "--world", str(blend), "--from", "0", "0", "0", "--distance", "3", "--speed", "0.5"
    )
    assert (out / "raw" / "000000.ply").exists()


@pytest.mark.parametrize("stop, code", [(KeyboardInterrupt, None), (Terminated, 143)])
def test_an_interrupted_drive_leaves_nothing(tmp_path, monkeypatch, stop, code):
    def interrupt(self, result):
        raise stop()

    monkeypatch.setattr(bag_module.BagFeed, "clouds", interrupt)
    out = tmp_path / "out"
    request = DriveRequest(
        out=str(out), seed=SEED, detail="low", trail=True, scans=1, sensor=SensorConfig(rh_deg=RH)
    )
    if code is None:
        with pytest.raises(KeyboardInterrupt):
            run_drive(request, say=lambda text: None)
    else:
        with pytest.raises(Interrupted) as caught:
            run_drive(request, say=lambda text: None)
        assert caught.value.code == code
    assert list(out.iterdir()) == []  # no staging folder, no file


def test_wind_moves_foliage_and_keeps_labels_exact(tmp_path):
    from wildscan.core.world import plan_world
    from wildscan.core.world.cover import COVER_CLASSES, COVER_INSTANCE_BASE
    from wildscan.raycast.from_plan import plan_geometry

    clouds = {}
    for wind in (0.0, 4.0):
        out = tmp_path / f"wind{wind:g}"
        request = DriveRequest(
            out=str(out),
            seed=SEED,
            detail="low",
            trail=True,
            scans=1,
            sensor=SensorConfig(rh_deg=3.0),
            bag="none",
            wind=wind,
        )
        run_drive(request, say=lambda text: None)
        clouds[wind], _ = read_ply(out / "deskewed" / "000000.ply")
    geometry = plan_geometry(plan_world(SEED, "low"))
    class_of = dict(zip(geometry.instance.tolist(), geometry.class_id.tolist()))
    class_of.update({COVER_INSTANCE_BASE + c: c for c in COVER_CLASSES})  # the sward's returns
    windy = clouds[4.0]
    assert all(class_of[int(i)] == int(c) for i, c in zip(windy["instance"], windy["label"]))
    calm = clouds[0.0]
    key = lambda c: {(int(r), int(s)): k for k, (r, s) in enumerate(zip(c["ring"], c["sweep"]))}  # noqa: E731
    calm_at, moved = key(calm), 0
    for k, (r, s) in enumerate(zip(windy["ring"], windy["sweep"])):
        j = calm_at.get((int(r), int(s)))
        if j is not None and windy["label"][k] == 3 and calm["label"][j] == 3:
            moved += abs(float(windy["x"][k]) - float(calm["x"][j])) > 1e-3
    assert moved > 50  # treetops sway


def test_drive_along_the_trail_of_a_saved_world(tmp_path):
    """--world: the .blend is extracted with bpy; its trail is the one its seed's layout drew."""
    from wildscan.app.drive.world import layout_of
    from wildscan.core.world import plan_world

    assert np.array_equal(layout_of(SEED).trail.path, plan_world(SEED, "low").layout.trail.path)
    blend = tmp_path / "w.blend"
    assert (
        run(
            [WILDSCAN, "world", "--seed", str(SEED), "--detail", "low", "--quiet", "--out", str(blend)]
        ).returncode
        == 0
    )
    out = drive_cli(tmp_path, "--world", str(blend), "--trail", "--scans", "1")
    summary = json.loads((out / "drive.json").read_text())
    assert summary["world"]["seed"] == SEED and summary["path"]["kind"] == "trail"


@pytest.mark.parametrize(
    "signum, code, says", [(2, 130, "interrupted; nothing written"), (15, 143, "terminated; nothing written")]
)
def test_a_signal_mid_drive_ends_it_and_leaves_nothing(tmp_path, signum, code, says):
    import os
    import time

    out = tmp_path / "out"
    proc = started(
        [WILDSCAN, "drive", "--seed", str(SEED), "--detail", "low", "--trail", "--quiet", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not (out.exists() and any(out.iterdir())) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    time.sleep(0.3)  # well inside the sweeps
    os.kill(proc.pid, signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert err.strip().splitlines()[-1].endswith(says) and "Traceback" not in err
    assert list(out.iterdir()) == []


def test_a_drive_in_weather_writes_the_weather_field_in_both_bags_readable_by_rosbags(tmp_path):
    """--weather with --bag both: every PointCloud2 lists the `weather` field, rosbags reads it
    from the ROS 1 and the ROS 2 bag, and it equals the raw PLY's; the clear drive's layout
    (above) keeps its 32 bytes a point."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from wildscan.core.io.rosbag import WEATHER_POINT_DTYPE

    out = tmp_path / "d"
    sensor = SensorConfig(rh_deg=RH)
    request = DriveRequest(str(out), seed=SEED, detail="low", trail=True, sensor=sensor, scans=None)
    from dataclasses import replace

    request = replace(_limited(request, out), weather={"snow": 30.0, "fog": 60.0})
    run_drive(request, say=lambda text: None)
    raw, _ = read_ply(out / "raw" / "000001.ply")
    assert (raw["weather"] > 0).sum() > 10
    for bag in (out / "drive.bag", out / "drive_ros2"):
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
            clouds = [
                reader.deserialize(data, conn.msgtype)
                for conn, _, data in reader.messages()
                if conn.topic == "/points"
            ]
        cloud = clouds[-1]
        assert [f.name for f in cloud.fields][-1] == "weather" and cloud.point_step == 36, bag
        points = np.frombuffer(bytes(cloud.data), dtype=WEATHER_POINT_DTYPE)
        assert np.array_equal(points["weather"], raw["weather"])
        assert np.array_equal(points["label"], raw["label"])


def test_scans_states_one_allowed_range_in_its_help_and_every_message(tmp_path):
    said = set()
    for value in ("-1", "0", "10001"):
        proc = run(
            [WILDSCAN, "drive", "--seed", str(SEED), "--trail", "--scans", value, "--out", str(tmp_path)]
        )
        assert proc.returncode == 2
        said.add(user_error_line(proc).split("must be ")[1].split(", got")[0])
    try:
        DriveRequest(out=str(tmp_path), seed=SEED, trail=True, scans=0).check()
    except Exception as e:  # the API says it as the command line does
        said.add(str(e).split("must be ")[1].split(", got")[0])
    assert said == {"a whole number from 1 to 10000"}
    help_text = run([WILDSCAN, "drive", "--help"]).stdout
    assert "3D scans to take, 1 to 10000" in " ".join(help_text.split())


def test_a_re_drive_without_bags_leaves_no_empty_bag_folder_and_keeps_a_users_file(tmp_path):
    from wildscan.app.drive.files import remove_emptied_folders

    out = tmp_path / "out"
    for bag in ("ros2", "none"):
        request = DriveRequest(
            out=str(out),
            seed=SEED,
            detail="low",
            trail=True,
            scans=1,
            sensor=SensorConfig(rh_deg=RH),
            bag=bag,
        )
        run_drive(request, say=lambda text: None)
        if bag == "ros2":
            assert any((out / "drive_ros2").iterdir())
    assert not (out / "drive_ros2").exists()
    assert (out / "raw" / "000000.ply").exists()
    # a folder that holds a file of the user's is never removed
    (out / "mine").mkdir()
    (out / "mine" / "notes.txt").write_text("mine")
    remove_emptied_folders(out, "mine/drive.bag")
    assert (out / "mine" / "notes.txt").read_text() == "mine"


def test_every_staged_file_is_synced_before_it_is_moved_into_place(tmp_path, monkeypatch):
    """A bag writer fills its file through `Staging.path`, not `write`: commit syncs it too."""
    from wildscan.app.drive import files

    synced = []
    monkeypatch.setattr(files, "_fsync", lambda path: synced.append(path.relative_to(stage.dir).as_posix()))
    stage = files.Staging(tmp_path)
    stage.write("raw/000000.ply", b"ply")
    stage.path("drive_ros2/drive_ros2.mcap").write_bytes(b"mcap")
    stage.path("drive.bag").write_bytes(b"bag")
    written = stage.commit()
    assert sorted(synced) == sorted(written) == ["drive.bag", "drive_ros2/drive_ros2.mcap", "raw/000000.ply"]
    assert (tmp_path / "drive.bag").read_bytes() == b"bag"
