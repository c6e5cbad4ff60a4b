"""The add-on's World panel on the endless layout, on the bpy wheel (headless): Generate builds a
region (centre and size), a scan there runs, a pose whose sensor reaches past the region is
warned about, and Extend region rebuilds a region holding that reach."""

from __future__ import annotations

import bpy
import numpy as np
import pytest

import wildscan
from wildscan.core.placement import Pose
from wildscan.core.world.region import Region, reach_beyond

from tests.helpers.scene_helpers import fresh_scene

pytestmark = pytest.mark.slow  # builds tiles of the endless world

CENTRE, SIZE = (50.0, 50.0), 40.0  # a small region: a few tiles


@pytest.fixture(scope="module", autouse=True)
def addon():
    wildscan.register()
    yield
    wildscan.unregister()


@pytest.fixture
def settings():
    fresh_scene()
    s = bpy.context.scene.wildscan
    s.seed, s.detail, s.vegetation, s.rh = 2, "low", "solid", 6.0
    return s


def test_generate_builds_the_region_and_extend_grows_it_to_the_sensors_reach(settings):
    from wildscan.app.scan import crop_radius
    from wildscan.ui import status
    from wildscan.ui.properties import sensor_from
    from wildscan.ui.region import built_region, reach_warning

    assert settings.world_layout == "endless"  # the default layout
    settings.region_x, settings.region_y = CENTRE
    settings.region_size = SIZE
    assert bpy.ops.wildscan.generate_world() == {"FINISHED"}
    scene = bpy.context.scene
    assert built_region(scene) == Region(30.0, 30.0, 70.0, 70.0)
    sensor = sensor_from(settings)

    # a valid pose near the middle: the scan runs and its reach stays inside, no warning
    rng = np.random.default_rng(0)
    pose = next(
        p
        for p in (Pose(50 + dx, 50 + dy, 30.0) for dx, dy in rng.uniform(-4, 4, (40, 2)))
        if status.check_pose(p, None).ok
    )
    settings.pose_x, settings.pose_y, settings.pose_yaw = pose.x, pose.y, pose.yaw_deg
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    assert reach_warning(scene, pose, sensor) is None

    # towards the edge: the sensor's reach leaves the region, the scan says so
    edge = Pose(66.0, 50.0, 0.0)
    warning = reach_warning(scene, edge, sensor)
    assert warning is not None and "past the built region" in warning and "Extend region" in warning
    settings.pose_x, settings.pose_y = edge.x, edge.y
    assert bpy.ops.wildscan.extend_region() == {"FINISHED"}
    grown = built_region(scene)
    assert grown.contains(Region(30.0, 30.0, 70.0, 70.0))
    assert reach_beyond(grown, edge.x, edge.y, crop_radius(sensor)) == 0.0
    assert reach_warning(scene, edge, sensor) is None
    assert (settings.region_x, settings.region_y) == pytest.approx(grown.centre)


def test_the_paper_layout_builds_the_island_and_records_no_region(settings):
    from wildscan.ui.region import built_region

    settings.world_layout = "paper"
    assert bpy.ops.wildscan.generate_world() == {"FINISHED"}
    assert built_region(bpy.context.scene) is None
    assert not bpy.ops.wildscan.extend_region.poll()
