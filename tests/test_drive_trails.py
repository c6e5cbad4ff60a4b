"""Drives over the endless world's trail network (`drive --seed S --trail --distance M`,
issue 34): the route node to node, the world built piece by piece along it (continuity
across pieces and tiles), the loop's closure, the bag read back by rosbags."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wildscan.app.drive import DriveRequest, run_drive
from wildscan.app.drive.trails import PIECE_M, pieces
from wildscan.core.errors import UserError
from wildscan.core.io.tum import read_tum
from wildscan.core.motion.routes import trail_route
from wildscan.core.world.endless import TILE_M, trail_network

SEED = 1
SPEED = 2.0  # m/s: fewer 2D scans for the same road
# 14 3D scans of 9 m (180 UTM 2D scans at 2 m/s): the way back starts its scans where the
# way out started its own, so the revisits of the loop are pairs 0 m apart
LOOP_M = 126.0


def _lengths(points: np.ndarray) -> np.ndarray:
    return np.hypot(*np.diff(points, axis=0).T)


def test_the_route_follows_the_network_node_to_node_for_its_distance_and_the_loop_comes_back():
    network = trail_network(SEED, "mixed", -1500, -1500, 1500, 1500)
    out = trail_route(network, (0.0, 0.0), 1200.0, "out")
    assert _lengths(out).sum() == pytest.approx(1200.0, abs=1e-6)
    # every vertex of the route is a vertex of some trail, or the start / the end cut
    vertices = {tuple(np.round(p, 6)) for path, _ in network for p in path}
    inner = [tuple(np.round(p, 6)) for p in out[1:-1]]
    assert all(p in vertices for p in inner)
    # it passes junctions: more than one trail of the network is driven
    assert len(out) > max(len(path) for path, _ in network)
    loop = trail_route(network, (0.0, 0.0), 1200.0, "loop")
    assert _lengths(loop).sum() == pytest.approx(1200.0, abs=1e-6)
    assert np.array_equal(loop[0], loop[-1]) and np.array_equal(loop[0], out[0])
    assert np.array_equal(trail_route(network, (0.0, 0.0), 1200.0, "out"), out)  # deterministic


def test_pieces_are_whole_3d_scans_of_about_the_piece_length():
    runs = pieces(4_000, 180, 0.025, True)
    assert runs[0][0] == 0 and runs[-1][1] == 4_000
    assert all(b == c for (_, b), (c, _) in zip(runs[:-1], runs[1:]))
    assert all((b - a) % 180 == 0 for a, b in runs[:-1])
    assert all((b - a) * 0.025 <= PIECE_M for a, b in runs[:-1])
    assert pieces(4_000, 180, 0.025, False) == [(0, 4_000)]


@pytest.fixture(scope="module")
def loop_drive(tmp_path_factory):
    out = tmp_path_factory.mktemp("trail") / "d"
    request = DriveRequest(
        str(out), seed=SEED, trail=True, distance=LOOP_M, route="loop", speed=SPEED, bag="ros2"
    )
    report = run_drive(request, say=lambda text: None)
    return out, report


def test_a_loop_drive_crosses_pieces_and_tiles_without_a_jump_and_closes(loop_drive):
    out, report = loop_drive
    tum = read_tum((out / "trajectory.tum").read_text())
    xyz = tum[:, 1:4]
    steps = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    period = 0.025  # the UTM-30LX-EW's 2D scan
    assert steps.max() < SPEED * period + 0.05  # no jump where one piece's triangles meet the next's
    assert _lengths(xyz[:, :2]).sum() >= LOOP_M - 1 - SPEED * period * 180
    tiles = {tuple(np.floor(p / TILE_M).astype(int)) for p in xyz[:, :2]}
    assert len(tiles) >= 2  # the path crosses tiles
    assert report.distance == pytest.approx(LOOP_M, abs=SPEED * period * 180)
    # the loop's closure: it ends where it started (within the last, partial, 2D scan's road)
    assert np.linalg.norm(xyz[-1, :2] - xyz[0, :2]) < SPEED * period * 2
    summary = json.loads((out / "drive.json").read_text())
    assert summary["request"]["route"] == "loop" and summary["world"]["layout"] == "endless"
    revisits = json.loads((out / "revisits.json").read_text())["sequences"]["00"]["positives"]
    assert revisits  # going back, the robot passes its own first scans' places


def test_a_loop_drives_bag_has_clouds_imu_and_tf_static_read_by_rosbags(loop_drive):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out, report = loop_drive
    counts: dict[str, int] = {}
    with AnyReader([out / "drive_ros2"], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        for conn, _, data in reader.messages():
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
            if conn.topic == "/points_deskewed":
                cloud = reader.deserialize(data, conn.msgtype)
                assert cloud.width > 1000
    assert types["/points"] == "sensor_msgs/msg/PointCloud2" and types["/imu"] == "sensor_msgs/msg/Imu"
    assert types["/tf_static"] == "tf2_msgs/msg/TFMessage" and counts["/tf_static"] == 1
    assert counts["/points"] == report.scans_3d and counts["/imu"] > 200 * report.duration * 0.99


@pytest.mark.parametrize(
    "change, setting",
    [
        (dict(distance=10.0, route="loop", trail=False, start=(0.0, 0.0, 0.0)), "route"),
        (dict(distance=-5.0), "distance"),
        (dict(distance=1e6), "distance"),
        (dict(route="round"), "route"),
    ],
)
def test_a_trail_drive_refuses_bad_settings_by_name(tmp_path, change, setting):
    fields = dict(seed=SEED, trail=True, distance=100.0, bag="none") | change
    with pytest.raises(UserError) as e:
        DriveRequest(str(tmp_path / "d"), **fields).check()
    assert e.value.setting == setting


def test_a_trail_the_robot_cannot_drive_is_never_taken():
    """A cross of four trails from the node (0, 0): going east from the west arm, the route
    would go straight on; with the east arm undrivable it turns, and it never starts on it."""
    arms = {
        name: np.array([[0.0, 0.0], end]) for name, end in (("east", [100.0, 0.0]), ("west", [-100.0, 0.0]))
    }
    arms |= {
        name: np.array([[0.0, 0.0], end]) for name, end in (("north", [0.0, 100.0]), ("south", [0.0, -100.0]))
    }
    network = [(path, "track") for path in arms.values()]
    every = trail_route(network, (-60.0, 1.0), 150.0)
    assert np.array_equal(every[-1], [90.0, 0.0])  # from the west arm straight on east

    def drivable(path):
        return not np.array_equal(path[-1], arms["east"][-1])

    route = trail_route(network, (-60.0, 1.0), 150.0, drivable=drivable)
    assert np.all(route[:, 0] <= 0.0) and _lengths(route).sum() == pytest.approx(150.0)
    assert np.array_equal(route[-1], [0.0, 90.0])  # north: as straight as south, listed first
    start = trail_route(network, (30.0, 1.0), 10.0, drivable=drivable)
    assert not np.any((start[:, 0] > 0) & (start[:, 1] == 0))  # not on the east arm, though nearest


def test_a_trail_drive_is_the_same_bytes_built_fresh_or_from_the_world_cache(tmp_path):
    """80 m at 4 m/s: two pieces (3D scans of 18 m, two to a piece of PIECE_M), tiles built
    the first time and read from the world cache the second: every file the same bytes."""
    assert len(pieces(800, 180, 0.1, True)) == 2
    from wildscan.app.cache.store import DiskCache

    cache = DiskCache(tmp_path / "cache", 10**10)
    files = []
    for run in ("built", "cached"):
        out = tmp_path / run
        request = DriveRequest(str(out), seed=SEED, trail=True, distance=80.0, speed=4.0, bag="ros2")
        run_drive(request, say=lambda text: None, cache=cache)
        files.append({p.relative_to(out): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()})
    assert files[0].keys() == files[1].keys() and len(files[0]) > 10
    assert all(files[0][k] == files[1][k] for k in files[0]), [
        k for k in files[0] if files[0][k] != files[1][k]
    ]
    assert any(p.name.startswith("tile-") for p in (tmp_path / "cache").rglob("*"))
