"""`wildscan drive`: timing, trajectories, raw vs deskewed clouds, and the static scan it
reduces to when the robot stands still."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.app.drive import DriveRequest, run_drive
from wildscan.app.scan import crop_radius, scan_current_scene
from wildscan.core.io.ply import read_ply
from wildscan.core.io.tum import read_tum
from wildscan.core.motion import placements, sweep, timing, trajectory
from wildscan.core.placement import Pose, place
from wildscan.core.pointcloud import PLY_FIELDS
from wildscan.core.sensors import SensorConfig
from wildscan.core.spatial.rotations import quaternions
from wildscan.core.world import plan_world
from wildscan.raycast.from_plan import plan_geometry
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.select import make_backend

SEED, DETAIL = 1, "low"


@pytest.fixture(scope="module")
def world():
    plan = plan_world(SEED, DETAIL)
    return plan, plan_geometry(plan)


def trail_pose(plan, i: int = 40) -> Pose:
    path = plan.layout.trail.path
    d = path[i + 1] - path[i]
    return Pose(float(path[i, 0]), float(path[i, 1]), float(np.degrees(np.arctan2(d[1], d[0]))))


def static_fields(cloud_records: np.ndarray) -> bytes:
    """The bytes of the PLY fields every scan has (not the drive's `time`)."""
    from numpy.lib.recfunctions import repack_fields

    return repack_fields(cloud_records[[name for name, _ in PLY_FIELDS]]).tobytes()


@pytest.mark.slow
@pytest.mark.parametrize("frame", ["sensor", "leveled", "world"])
@pytest.mark.parametrize("noise", [0.0, 0.015])
def test_standing_still_equals_the_static_scan(world, tmp_path, frame, noise):
    """Speed 0 for one 3D scan, stepped head: raw and deskewed clouds are the static scan of the
    same pose in the same frame, point for point, label for label, byte for byte."""
    plan, geometry = world
    pose = trail_pose(plan)
    sensor = SensorConfig(rh_deg=2.0, noise_sigma=noise, noise_seed=7)
    static = scan_current_scene(pose, sensor, frame, geometry=geometry, notify=None)
    request = DriveRequest(
        out=str(tmp_path),
        seed=SEED,
        detail=DETAIL,
        start=(pose.x, pose.y, pose.yaw_deg),
        distance=0.0,
        speed=0.0,
        sensor=sensor,
        frame=frame,
        bag="none",
    )
    report = run_drive(request, say=lambda text: None)
    assert report.scans_3d == 1 and report.points == [len(static.cloud)]
    want = static.cloud.to_structured()
    for kind in ("raw", "deskewed"):
        got, _ = read_ply(tmp_path / kind / "000000.ply")
        assert static_fields(got) == want.tobytes(), kind
        assert np.allclose(
            got["time"], got["sweep"] * 0.025 + got["ring"] * (0.025 / 1440), rtol=0, atol=1e-12
        )


def pole_world() -> object:
    """Flat terrain at z = 0 and a square pole 0.2 m wide, 3 m tall, at (4, 1.5)."""
    ground = [[[-50, -50, 0], [50, -50, 0], [50, 50, 0]], [[-50, -50, 0], [50, 50, 0], [-50, 50, 0]]]
    x0, y0, a, h = 4.0, 1.5, 0.1, 3.0
    c = np.array([[x0 + sx * a, y0 + sy * a] for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    sides = []
    for i in range(4):
        p, q = c[i], c[(i + 1) % 4]
        sides += [[[*p, 0], [*q, 0], [*q, h]], [[*p, 0], [*q, h], [*p, h]]]
    tris = np.array(ground + sides, dtype=np.float64)
    class_id = [1, 1] + [12] * len(sides)
    instance = [1, 1] + [7] * len(sides)
    return from_triangles(tris, class_id, instance), (x0, y0, a, h)


def drive_straight(backend, speed: float, distance: float, sensor: SensorConfig, head: str = "stepped"):
    path = trajectory.straight_path(0.0, 0.0, 0.0, distance)
    plan = trajectory.schedule(path, speed, sensor.sweeps, 1)
    times, xy, yaw = trajectory.instants(path, speed, plan.scans_2d + 1)
    motion = placements.place_all(backend, times, xy, yaw, speed * times)
    noise = np.zeros(plan.scans_2d * 1080)
    return motion, sweep.sweep(backend, motion, 0, plan.scans_2d, sensor, head, noise, "world")


@pytest.mark.slow
@pytest.mark.parametrize("head", ["stepped", "continuous"])
def test_driving_past_a_pole_skews_the_raw_cloud_and_deskewing_undoes_it(head):
    geometry, (x0, y0, a, h) = pole_world()
    backend = make_backend("auto", geometry=geometry, notify=None)
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0)
    motion, result = drive_straight(backend, 1.0, 2.0, sensor, head)
    raw, true = result.raw, result.deskewed
    assert np.array_equal(raw.label, true.label) and np.array_equal(raw.extra["time"], true.extra["time"])
    pole = true.label == 12
    assert pole.sum() > 100
    # deskewed: every pole point on the pole's surface (a 0.2 m square), within 1e-4 m
    p = true.xyz[pole]
    box = np.maximum(np.abs(p[:, 0] - x0), np.abs(p[:, 1] - y0))
    assert np.abs(box - a).max() < 1e-4
    assert p[:, 2].min() > -1e-4 and p[:, 2].max() < h + 1e-4
    # raw: displaced against the motion (+x at 1 m/s) by the distance driven by each point's time
    t = raw.extra["time"][pole]
    shift = true.xyz[pole] - raw.xyz[pole]
    assert np.abs(shift[:, 0] - 1.0 * t).max() < 1e-4
    assert np.abs(shift[:, 1:]).max() < 1e-4
    assert t.min() > 0.1  # seen > 0.1 s into the scan: the raw pole stands > 10 cm off the real one
    q = raw.xyz[pole]
    raw_box = np.maximum(np.abs(q[:, 0] - x0), np.abs(q[:, 1] - y0))
    assert np.abs(raw_box - a).min() > 0.05 or np.abs(q[:, 0] - x0).max() > a + 0.05
    # and the robot stood level on flat ground the whole way
    assert np.allclose(motion.centre[:, 2], 0.723) and np.allclose(motion.centre[-1, 0], 45 * 0.025)


def test_times_rise_with_the_beam_and_the_2d_scan():
    k = np.arange(50)
    t = timing.beam_times(k)
    assert np.all(np.diff(t, axis=1) > 0) and np.all(np.diff(t.ravel()) > 0)
    assert t[0, 0] == 0 and abs(t[3, 0] - 3 * 0.025) < 1e-15
    assert abs((t[0, -1] - t[0, 0]) - 1079 * 0.025 / 1440) < 1e-15
    assert abs(timing.FIELD_SWEEP_TIME - 0.01875) < 1e-15
    head = timing.head_angles_rad(k, 1.0, "continuous")
    assert np.all(np.diff(head.ravel()) > 0) and np.allclose(head[:, 0], np.radians(k))
    assert np.allclose(timing.head_angles_rad(k, 1.0, "stepped"), np.radians(k))


def test_points_time_rises_in_a_drive():
    geometry, _ = pole_world()
    backend = make_backend("auto", geometry=geometry, notify=None)
    _, result = drive_straight(backend, 1.0, 2.0, SensorConfig(rh_deg=4.0, noise_sigma=0.0))
    cloud = result.raw
    order = np.lexsort((cloud.ring, cloud.sweep))
    assert np.all(order == np.arange(len(order)))  # points come sweep by sweep, beam by beam
    assert np.all(np.diff(cloud.extra["time"]) > 0)


@pytest.mark.slow
def test_trajectory_matches_the_placement_at_every_2d_scan(world, tmp_path):
    plan, geometry = world
    sensor = SensorConfig(rh_deg=6.0, noise_sigma=0.0)
    request = DriveRequest(
        out=str(tmp_path), seed=SEED, detail=DETAIL, trail=True, scans=1, sensor=sensor, bag="none"
    )
    report = run_drive(request, say=lambda text: None)
    rows = read_tum((tmp_path / "trajectory.tum").read_text())
    assert len(rows) == report.scans_2d == 30
    path = trajectory.polyline_path(plan.layout.trail.path, "trail", "trail")
    times, xy, yaw = trajectory.instants(path, 1.0, len(rows))
    backend = make_backend("auto", geometry=geometry.cropped(xy[0], crop_radius(sensor) + 2), notify=None)
    assert np.allclose(rows[:, 0], times, atol=1e-6)
    for row, (x, y), heading in zip(rows, xy, yaw):
        placed = place(backend, Pose(float(x), float(y), float(heading)))
        assert np.allclose(row[1:4], placed.optical_centre, atol=2e-9)
        assert np.allclose(row[4:], quaternions(placed.rotation), atol=2e-12)


def test_heading_follows_the_path_without_jumps():
    path = trajectory.polyline_path([[0, 0], [10, 0], [10, 10]], "waypoints", "waypoints")
    xy, yaw = path.at(np.array([0.0, 4.0, 9.5, 9.75, 10.0, 10.25, 10.5, 15.0, 20.0]))
    assert np.allclose(xy[[0, 1, 4, 7, 8]], [[0, 0], [4, 0], [10, 0], [10, 5], [10, 10]])
    assert np.allclose(yaw, [0, 0, 0, 22.5, 45, 67.5, 90, 90, 90])
    turning = trajectory.polyline_path([[0, 0], [1, 0], [1, -1]], "waypoints", "waypoints")
    assert np.allclose(turning.at(np.array([0.5, 1.0, 1.5]))[1], [0, -45, -90])
    straight = trajectory.straight_path(1.0, 2.0, 30.0, 5.0)
    assert straight.at(np.array([0.0, 5.0]))[1].tolist() == [30.0, 30.0]
    assert abs(straight.length - 5.0) < 1e-12


def test_schedule_counts_2d_and_3d_scans():
    path = trajectory.straight_path(0, 0, 0, 60.0)
    plan = trajectory.schedule(path, 1.0, 180)
    assert (plan.scans_2d, plan.scans_3d) == (2400, 13)
    assert trajectory.schedule(path, 0.0, 180).scans_2d == 180
    assert trajectory.schedule(path, 1.0, 180, 2).scans_2d == 360


@pytest.mark.slow
@pytest.mark.parametrize("head", ["stepped", "continuous"])
def test_deskewing_holds_while_the_robot_turns(head):
    """Around bends the attitude turns during every 2D scan: the deskewed pole still stands
    where it is (1e-4 m), the raw one does not."""
    geometry, (x0, y0, a, h) = pole_world()
    backend = make_backend("auto", geometry=geometry, notify=None)
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0)
    path = trajectory.polyline_path([[0, 0], [0.6, 0.1], [0.9, 0.6], [0.8, 1.2]], "waypoints", "waypoints")
    plan = trajectory.schedule(path, 1.0, sensor.sweeps, 1)
    times, xy, yaw = trajectory.instants(path, 1.0, plan.scans_2d + 1)
    motion = placements.place_all(backend, times, xy, yaw, times)
    assert np.ptp(yaw) > 60 and np.count_nonzero(np.any(motion.step != 0, axis=1)) > 20
    noise = np.zeros(plan.scans_2d * 1080)
    result = sweep.sweep(backend, motion, 0, plan.scans_2d, sensor, head, noise, "world")
    pole = result.deskewed.label == 12
    assert pole.sum() > 50
    p = result.deskewed.xyz[pole]
    assert np.abs(np.maximum(np.abs(p[:, 0] - x0), np.abs(p[:, 1] - y0)) - a).max() < 1e-4
    ground = result.deskewed.label == 1
    assert np.abs(result.deskewed.xyz[ground, 2]).max() < 1e-4  # the ground is flat where it is
    q = result.raw.xyz[pole]
    assert np.abs(np.maximum(np.abs(q[:, 0] - x0), np.abs(q[:, 1] - y0)) - a).max() > 0.05


@pytest.mark.slow
def test_a_seeds_drive_world_has_the_vegetation_asked_for(world):
    from wildscan.app.drive.world import drive_world

    plan, porous = world
    solid = drive_world(DriveRequest(out="-", seed=SEED, detail=DETAIL, vegetation="solid"))
    assert solid.provenance == {"seed": SEED, "detail": DETAIL, "vegetation": "solid", "world": None}
    geometry = plan_geometry(solid.plan)
    assert (
        geometry.triangle_count == plan_geometry(plan_world(SEED, DETAIL, vegetation="solid")).triangle_count
    )
    assert geometry.triangle_count != porous.triangle_count
    np.testing.assert_array_equal(solid.instances, np.unique(geometry.instance))
    np.testing.assert_array_equal(solid.trail, plan.layout.trail.path)  # the layout does not depend on it


def test_a_drive_from_inside_the_cave_stands_on_its_floor_with_z_start_or_without(world, tmp_path):
    """With the z_start `wildscan poses` gives, every instant stands on the cave's floor; the
    default biome's cave roof is rock, which the probe from above passes, so without
    --z-start the drive stands on the floor too (in the paper biome the probe finds the roof,
    terrain there, first: tests/test_cover.py)."""
    from wildscan.app.poses import valid_poses

    plan, geometry = world
    backend = make_backend("auto", geometry=geometry, notify=None)
    inside = next(p for p in valid_poses(plan, backend, zones=("cave",))["cave"] if p.get("z_start"))
    common = dict(
        seed=SEED,
        detail=DETAIL,
        start=(inside["x"], inside["y"], inside["yaw"]),
        distance=1.0,
        speed=0.5,
        scans=1,
        sensor=SensorConfig(rh_deg=6.0),
        bag="none",
    )
    z = {}
    for name, z_start in (("probed", None), ("under", inside["z_start"])):
        run_drive(DriveRequest(out=str(tmp_path / name), z_start=z_start, **common), say=lambda text: None)
        z[name] = read_tum((tmp_path / name / "trajectory.tum").read_text())[:, 3]  # optical centre z
    assert np.all(z["under"] < inside["z_start"]), z["under"]
    assert np.allclose(z["under"], inside["optical_centre_z"], atol=0.1)
    np.testing.assert_array_equal(z["probed"], z["under"])  # the rock roof is no ground
