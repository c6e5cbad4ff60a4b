"""The triangles a scan's beams can reach (raycast/beam_reach.py) and the LOD scan that leaves
the others out (app/scan.py endless_scan_geometry): every triangle a beam meets is kept, most
far ones are not, and the scan's points are the very bytes of a scan over every triangle."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.app.scan import crop_radius, endless_scan_geometry, scan_current_scene
from wildscan.app.tile_memory import TileMemory
from wildscan.app.tiles import TiledWorld, scan_levels, tiles_geometry
from wildscan.core.placement import Pose
from wildscan.core.sensors import SensorConfig, device_named
from wildscan.raycast.beam_reach import BeamGrid


def met_by_rays(origin, dirs, corners) -> np.ndarray:
    """(T,) whether any ray meets each triangle (Moller-Trumbore in float64, both faces)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    e1, e2 = b - a, c - a
    met = np.zeros(len(corners), dtype=bool)
    for d in dirs:
        p = np.cross(np.broadcast_to(d, e2.shape), e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = origin - a
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        met |= ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return met


def test_every_triangle_a_beam_meets_is_kept_and_most_far_small_ones_are_not():
    rng = np.random.default_rng(7)
    origin = np.array([3.0, -2.0, 1.5])
    # a fan of beams like a spinning lidar's: 16 rings 2 deg apart, a column every 1 deg
    el = np.radians(np.arange(-15.0, 16.0, 2.0))
    az = np.radians(np.arange(0.0, 360.0, 1.0))
    e, a = np.meshgrid(el, az)
    dirs = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1).reshape(-1, 3)
    # small leaves 5-80 m away round the sensor, and a few big near ones (seen over wide arcs)
    n = 3000
    distance = rng.uniform(5.0, 80.0, n)
    heading = rng.uniform(-np.pi, np.pi, n)
    centre = origin + np.stack(
        [distance * np.cos(heading), distance * np.sin(heading), rng.uniform(-8.0, 12.0, n)], -1
    )
    corners = centre[:, None, :] + rng.normal(0.0, 0.15, (n, 3, 3))
    big = origin + rng.uniform(-3.0, 3.0, (50, 3, 3))
    corners = np.concatenate([corners, big])
    vertices, faces = corners.reshape(-1, 3), np.arange(3 * len(corners)).reshape(-1, 3)
    kept = BeamGrid(dirs).reachable(vertices, faces, origin)
    met = met_by_rays(origin, dirs, corners)
    assert met.sum() > 100  # the test has beams meeting leaves to lose
    assert not (met & ~kept).any()  # none a beam meets is left out
    assert kept[:n].mean() < 0.6  # and the leaves between the beams are


def test_around_keeps_the_triangles_near_a_point_whatever_the_beams():
    dirs = np.array([[1.0, 0.0, 0.0]])
    corners = np.array([[[-1.0, 1.0, -5.0], [-1.2, 1.0, -5.0], [-1.0, 1.2, -5.0]]])  # behind, below
    vertices, faces = corners.reshape(-1, 3), np.arange(3).reshape(1, 3)
    grid = BeamGrid(dirs)
    assert not grid.reachable(vertices, faces, np.zeros(3))[0]
    assert grid.reachable(vertices, faces, np.zeros(3), ((0.0, 0.0), 2.0))[0]


@pytest.mark.parametrize("model", ["paper", "realistic"])
def test_a_lod_scan_leaves_out_what_no_beam_meets_and_gives_the_same_bytes(model):
    """A VLP-16 (to 60 m: full detail, then level 1 and 2 tiles) at a meadow's edge of seed 0:
    the scan over the culled tiles equals the scan over all their triangles, bit for bit (the
    realistic model's sub-rays too: its margin holds the beam's divergence)."""
    settings = {"noise_sigma": 0.0} if model == "paper" else {"model": model}
    sensor = SensorConfig.for_device(device_named("vlp16"), max_range=60.0, **settings).validate()
    pose = Pose(58.0, -680.0, 0.0)
    reach = crop_radius(sensor)
    levels = scan_levels(sensor, pose.x, pose.y, reach, True)
    assert max(levels.values()) >= 1
    memory = TileMemory()
    world = TiledWorld(0, "mixed", "default", "porous")
    whole, _ = tiles_geometry(world, levels, None, memory, (pose.x, pose.y), radius=reach)
    culled, counts = endless_scan_geometry(0, pose, sensor, True, "mixed", "porous", memory=memory)
    assert counts.memory == len(levels)
    assert culled.triangle_count < 0.7 * whole.triangle_count
    a, b = (
        scan_current_scene(pose, sensor, "leveled", None, "embree", notify=lambda _t: None, geometry=g)
        for g in (whole, culled)
    )
    assert a.placement.to_dict() == b.placement.to_dict()
    assert len(a.cloud) > 10_000
    for name in ("xyz", "range", "label", "instance", "ring", "sweep", "intensity"):
        assert np.array_equal(getattr(a.cloud, name), getattr(b.cloud, name)), name


def test_lod_off_keeps_every_triangle():
    sensor = SensorConfig.for_device(device_named("vlp16"), max_range=30.0, noise_sigma=0.0).validate()
    pose = Pose(58.0, -680.0, 0.0)
    reach = crop_radius(sensor)
    memory = TileMemory()
    levels = scan_levels(sensor, pose.x, pose.y, reach, False)
    world = TiledWorld(0, "mixed", "default", "porous")
    whole, _ = tiles_geometry(world, levels, None, memory, (pose.x, pose.y), radius=reach)
    off, _ = endless_scan_geometry(0, pose, sensor, False, "mixed", "porous", memory=memory)
    assert off.triangle_count == whole.triangle_count
