"""Placement, leveling and the scan pipeline on exact analytic scenes (no Blender)."""

import math

import numpy as np
import pytest

from wildscan.core import placement as P
from wildscan.core.classes import WATER_ID
from wildscan.core.errors import PoseRejected, UserError
from wildscan.core.scan import run_scan
from wildscan.core.sensors import DEFAULT_DEVICE, SensorConfig, beam_directions, from_axis_rad
from wildscan.core.spatial.leveling import leveling_matrix, rot_z, sensor_to_world_matrix

from tests.helpers.analytic import AnalyticBackend, Patch, slope_plane

TERRAIN, ROCK = 1, 9
QUIET = SensorConfig(noise_sigma=0.0)


def flat_world(*extra):
    return AnalyticBackend([Patch((0, 0, 0), (0, 0, 1), TERRAIN), *extra])


def plane_with_attitude(roll_deg, pitch_deg, yaw_deg, z0=2.0):
    """The plane a structure with this attitude would rest on (normal = its column)."""
    n = sensor_to_world_matrix(math.radians(roll_deg), math.radians(pitch_deg), math.radians(yaw_deg)) @ [
        0,
        0,
        1,
    ]
    return Patch((0.0, 0.0, z0), tuple(n), TERRAIN)


@pytest.mark.parametrize(
    "roll, pitch, yaw",
    [(0, 0, 0), (5, 0, 0), (0, -7, 30), (12, 9, -120), (-15, 18, 200), (3.3, -20, 45)],
)
def test_placement_on_a_plane_of_known_slope_gives_its_roll_and_pitch(roll, pitch, yaw):
    backend = AnalyticBackend([plane_with_attitude(roll, pitch, yaw)])
    p = P.place(backend, P.Pose(1.5, -2.0, yaw))
    assert p.roll_deg == pytest.approx(roll, abs=0.1)
    assert p.pitch_deg == pytest.approx(pitch, abs=0.1)
    # The column is the plane normal and the optical centre is 0.723 m up it.
    normal = np.asarray(backend.patches[0].normal)
    assert np.allclose(p.rotation @ [0, 0, 1], normal / np.linalg.norm(normal), atol=1e-9)
    assert np.linalg.norm(p.optical_centre - p.ground_centre) == pytest.approx(P.COLUMN_HEIGHT)


def test_pitch_sign_follows_the_documented_convention():
    # Ground rising towards +X: the front laser's tip is higher, so the nose is up and pitch < 0.
    p = P.place(AnalyticBackend([slope_plane(0, 0.1, 0, class_id=TERRAIN)]), P.Pose(0, 0, 0))
    assert p.pitch_deg < 0 and abs(p.roll_deg) < 1e-9
    # Ground rising towards +Y: the left laser's tip is higher, so roll < 0.
    p = P.place(AnalyticBackend([slope_plane(0, 0, 0.1, class_id=TERRAIN)]), P.Pose(0, 0, 0))
    assert p.roll_deg < 0 and abs(p.pitch_deg) < 1e-9


def test_arm_tips_lie_inside_the_blind_cone():
    assert max(P.ARM_X, P.ARM_Y) < P.COLUMN_HEIGHT


def test_leveled_points_match_world_points_on_tilted_ground():
    backend = AnalyticBackend([plane_with_attitude(6, -8, 35, z0=1.0)])
    pose = P.Pose(0.5, 0.25, 35)
    leveled = run_scan(backend, pose, QUIET, frame="leveled")
    world = run_scan(backend, pose, QUIET, frame="world")
    c = world.placement.optical_centre
    assert abs(world.placement.roll_deg) >= 5 and abs(world.placement.pitch_deg) >= 5
    assert len(leveled.cloud) == len(world.cloud) > 50_000
    # World points really lie on the plane the beams hit…
    patch = backend.patches[0]
    n = np.asarray(patch.normal) / np.linalg.norm(patch.normal)
    assert np.abs((world.cloud.xyz - patch.point) @ n).max() < 1e-9
    # …and the leveled cloud is that same cloud, moved to the optical centre and turned by -yaw.
    expected = (world.cloud.xyz - c) @ rot_z(math.radians(-pose.yaw_deg)).T
    assert np.abs(leveled.cloud.xyz - expected).max() < 1e-4


def test_eq2_as_printed_is_not_a_rotation_but_the_fixed_one_is():
    b = math.radians(10)
    printed = np.array([[math.cos(-b), 0, -math.cos(-b)], [0, 1, 0], [math.sin(-b), 0, math.cos(-b)]])
    assert abs(np.linalg.det(printed) - 1) > 0.1
    fixed = leveling_matrix(0.0, b)
    assert np.allclose(fixed @ fixed.T, np.eye(3)) and np.linalg.det(fixed) == pytest.approx(1)


def test_sensor_frame_is_the_tilted_structure_frame():
    backend = AnalyticBackend([plane_with_attitude(-9, 6, 0)])
    pose = P.Pose(0, 0, 0)
    sensor = run_scan(backend, pose, SensorConfig(noise_sigma=0, rh_deg=4), frame="sensor")
    leveled = run_scan(backend, pose, SensorConfig(noise_sigma=0, rh_deg=4), frame="leveled")
    R = leveling_matrix(sensor.placement.roll_rad, sensor.placement.pitch_rad)
    assert np.allclose(sensor.cloud.xyz @ R.T, leveled.cloud.xyz, atol=1e-9)
    # In the sensor frame the ground is the plane z = -0.723 (the column is its normal).
    assert np.allclose(sensor.cloud.xyz[:, 2], -P.COLUMN_HEIGHT, atol=1e-9)


def predicted_flat_ground_count(h, min_range, max_range, sweeps):
    cos_t = np.cos(from_axis_rad(DEFAULT_DEVICE.beams))
    with np.errstate(divide="ignore"):
        rho = np.where(cos_t < 0, h / -cos_t, np.inf)
    # The test needs no beam sitting on a range limit, where rounding would decide.
    assert np.abs(rho - min_range).min() > 1e-6 and np.abs(rho - max_range).min() > 1e-6
    return sweeps * int(((rho >= min_range) & (rho <= max_range)).sum())


@pytest.mark.parametrize("rh, lo, hi", [(1, 0.1, 15), (2, 1.0, 5.0), (4, 0.1, 30), (0.5, 2.5, 12.0)])
def test_flat_open_ground_gives_exactly_the_predicted_point_count(rh, lo, hi):
    sensor = SensorConfig(rh_deg=rh, min_range=lo, max_range=hi, noise_sigma=0)
    result = run_scan(flat_world(), P.Pose(3, 4, 10), sensor)
    assert len(result.cloud) == predicted_flat_ground_count(P.COLUMN_HEIGHT, lo, hi, sensor.sweeps)
    assert result.placement.optical_centre[2] == pytest.approx(P.COLUMN_HEIGHT)


def test_noise_spread_matches_sigma_and_seeds_decide():
    sensor = SensorConfig(rh_deg=0.5, noise_sigma=0.015, noise_seed=7)
    backend = flat_world()
    noisy = run_scan(backend, P.Pose(0, 0, 0), sensor)
    assert len(noisy.cloud) >= 100_000
    dirs, _, _ = beam_directions(0.5)
    beam = noisy.cloud.sweep.astype(int) * 1080 + noisy.cloud.ring
    true_range = P.COLUMN_HEIGHT / -dirs[beam, 2]
    err = noisy.cloud.range - true_range
    assert abs(err.std() - 0.015) < 0.05 * 0.015
    assert abs(err.mean()) < 0.001
    again = run_scan(backend, P.Pose(0, 0, 0), sensor)
    other = run_scan(backend, P.Pose(0, 0, 0), SensorConfig(rh_deg=0.5, noise_seed=8))
    assert np.array_equal(again.cloud.xyz, noisy.cloud.xyz)
    assert not np.array_equal(other.cloud.range[:1000], noisy.cloud.range[:1000])


def test_water_returns_are_dropped():
    pond = Patch((0, 0, 0.3), (0, 0, 1), WATER_ID, 5, xy_box=(2, 6, -2, 2))
    with_pond = run_scan(flat_world(pond), P.Pose(0, 0, 0), QUIET, frame="world")
    without = run_scan(flat_world(), P.Pose(0, 0, 0), QUIET, frame="world")
    xy = with_pond.cloud.xyz
    on_water = (xy[:, 0] >= 2) & (xy[:, 0] <= 6) & (np.abs(xy[:, 1]) <= 2) & (np.abs(xy[:, 2] - 0.3) < 1e-6)
    assert not on_water.any()
    assert len(with_pond.cloud) < len(without.cloud)
    assert with_pond.metadata["water_returns_dropped"] > 0
    assert set(np.unique(with_pond.cloud.label)) == {TERRAIN}


def rejection(backend, pose, **kw):
    with pytest.raises(PoseRejected) as info:
        P.place(backend, pose, **kw)
    return str(info.value)


def test_pose_on_water_is_rejected_naming_each_laser():
    pond = Patch((0, 0, 0.3), (0, 0, 1), WATER_ID, 5, xy_box=(-5, 5, -5, 5))
    msg = rejection(flat_world(pond), P.Pose(0, 0, 0))
    for name in ("front (+X)", "rear (-X)", "left (+Y)", "right (-Y)"):
        assert f"laser {name} hit water" in msg


def test_pose_half_on_a_rock_names_only_the_lasers_on_it():
    rock = Patch((0, 0, 0.4), (0, 0, 1), ROCK, 3, xy_box=(0.2, 2, -2, 2))
    msg = rejection(flat_world(rock), P.Pose(0, 0, 0))
    assert "laser front (+X) hit rock" in msg
    assert "rear" not in msg and "left" not in msg


def test_pose_off_the_world_is_rejected():
    island = AnalyticBackend([Patch((0, 0, 0), (0, 0, 1), TERRAIN, xy_box=(-10, 10, -10, 10))])
    assert "off the world" in rejection(island, P.Pose(50, 0, 0))
    assert "hit nothing" in rejection(island, P.Pose(50, 0, 0), z_start=5.0)


def test_pose_on_a_steep_slope_is_rejected():
    assert "tilts" in rejection(AnalyticBackend([slope_plane(0, 0.6, 0, class_id=TERRAIN)]), P.Pose(0, 0, 0))


def test_pose_on_a_step_is_rejected_as_uneven():
    step = Patch((0, 0, 0.3), (0, 0, 1), TERRAIN, 2, xy_box=(0.1, 3, -3, 3))
    assert "uneven" in rejection(flat_world(step), P.Pose(0, 0, 0))


def test_canopy_overhead_does_not_fool_the_probe_but_z_start_can_go_under_a_roof():
    crown = Patch((0, 0, 4.0), (0, 0, 1), 3, 9, xy_box=(-3, 3, -3, 3))
    p = P.place(flat_world(crown), P.Pose(0, 0, 0))
    assert p.ground_centre[2] == pytest.approx(0.0)
    # A terrain roof (a cave cover) is ground seen from above unless z_start starts under it.
    roof = Patch((0, 0, 3.0), (0, 0, 1), TERRAIN, 2, xy_box=(-3, 3, -3, 3))
    assert P.place(flat_world(roof), P.Pose(0, 0, 0)).ground_centre[2] == pytest.approx(3.0)
    assert P.place(flat_world(roof), P.Pose(0, 0, 0), z_start=1.0).ground_centre[2] == pytest.approx(0.0)


def test_bad_pose_and_frame_are_user_errors():
    with pytest.raises(UserError, match="x must be a finite number") as info:
        P.place(flat_world(), P.Pose(float("nan"), 0, 0))
    assert info.value.setting == "pose"
    with pytest.raises(UserError, match="must be one of leveled, sensor, world") as info:
        run_scan(flat_world(), P.Pose(0, 0, 0), QUIET, frame="robot")
    assert info.value.setting == "frame" and info.value.allowed == ("leveled", "sensor", "world")
