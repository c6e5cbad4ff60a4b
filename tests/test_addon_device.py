"""The add-on's Sensor panel device: the preset menu (every preset of core/sensors) and a
sensor file of the user's own, on the bpy wheel (headless)."""

from __future__ import annotations

import bpy
import numpy as np
import pytest

import wildscan
from wildscan.app.scan import scan_current_scene
from wildscan.core.placement import Pose
from wildscan.core.sensors import DEFAULT_DEVICE, SensorConfig, preset_names
from wildscan.core.sensors.load import PRESETS_DIR

from tests.helpers.scene_helpers import CANDIDATE_XY, fresh_scene

pytestmark = pytest.mark.slow  # builds a world: `make test` runs it, `make test-fast` not

PRESET = (PRESETS_DIR / "utm30lx-ew.toml").read_text()


@pytest.fixture(scope="module", autouse=True)
def addon():
    wildscan.register()
    yield
    wildscan.unregister()


@pytest.fixture
def settings():
    fresh_scene()
    return bpy.context.scene.wildscan


def _file(tmp_path, text: str):
    path = tmp_path / "my_sensor.toml"
    path.write_text(text)
    return str(path)


def test_the_menu_lists_every_preset_then_the_sensor_file(settings):
    from wildscan.ui.device import FILE_CHOICE

    items = settings.bl_rna.properties["device"].enum_items
    assert [i.identifier for i in items] == [*preset_names(), FILE_CHOICE]
    assert settings.device == "utm30lx-ew"
    assert items["utm30lx-ew"].name == "Hokuyo UTM-30LX-EW"


def test_the_default_preset_scans_with_todays_sensor(settings):
    from wildscan.ui.properties import sensor_from

    sensor = sensor_from(settings)
    assert sensor == SensorConfig(noise_sigma=sensor.noise_sigma) and sensor.device == DEFAULT_DEVICE


def test_a_sensor_file_sets_the_fields_to_its_defaults_and_scans_as_its_device(settings, tmp_path):
    from wildscan.core.sensors import load_device
    from wildscan.ui.properties import sensor_from

    # the preset written as a user's file, with its own default r_h and range window
    text = PRESET.replace("step_deg = 1.0", "step_deg = 4.0").replace("max_m = 15.0", "max_m = 12.0")
    text = text.replace("[mount]\n", "[mount]\nheight = 1.5\n")  # and carried on a 1.5 m mast
    path = _file(tmp_path, text)
    settings.device = "FILE"
    settings.sensor_file = path
    assert (settings.rh, settings.max_range) == (4.0, 12.0) and settings.mount_height == 1.5
    sensor = sensor_from(settings)
    assert sensor.device == load_device(path) and sensor.sweeps == 45 and sensor.max_range == 12.0
    assert sensor.mount_height == 1.5
    settings.device = "utm30lx-ew"  # back to the preset: its defaults again
    assert (settings.rh, settings.max_range) == (1.0, 15.0)
    assert settings.mount_height == pytest.approx(0.723)
    settings.sensor_file = path  # a file while a preset is the choice changes nothing
    assert (settings.rh, settings.max_range) == (1.0, 15.0)


def test_a_panel_scan_with_a_sensor_file_equals_a_scan_with_that_device(settings, tmp_path):
    from wildscan.core.sensors import load_device
    from wildscan.ui import status
    from wildscan.ui.scene import clouds, read_cloud

    settings.seed, settings.detail, settings.world_layout = 5, "low", "paper"
    assert bpy.ops.wildscan.generate_world() == {"FINISHED"}
    pose = next(Pose(x, y, 30.0) for x, y in CANDIDATE_XY if status.check_pose(Pose(x, y, 30.0), None).ok)
    settings.pose_x, settings.pose_y, settings.pose_yaw = pose.x, pose.y, pose.yaw_deg
    path = _file(tmp_path, PRESET.replace("step_deg = 1.0", "step_deg = 4.0"))
    settings.device, settings.sensor_file = "FILE", path
    settings.noise = 0.0
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    (cloud,) = clouds(bpy.context.scene)
    sensor = SensorConfig.for_device(load_device(path), noise_sigma=0.0)
    expected = scan_current_scene(pose, sensor, "leveled").cloud
    got = read_cloud(cloud)
    assert len(got) == len(expected) > 1000
    # the same beams of the same device: every point's beam, class and range (the cloud object
    # keeps coordinates and a device's per-point times in single precision)
    for name in ("ring", "sweep", "label", "instance", "range"):
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
    np.testing.assert_allclose(got.xyz, expected.xyz, atol=1e-6)


@pytest.mark.parametrize(
    "text, match",
    [
        (None, "Sensor file is empty: choose a device file"),
        ("", "my_sensor.toml"),  # an empty file: no device in it
        (PRESET.replace("count = 1080", "count = 0"), "count"),
    ],
)
def test_a_sensor_file_that_cannot_be_used_is_a_report_and_scans_nothing(settings, tmp_path, text, match):
    from wildscan.ui.scene import clouds

    settings.device = "FILE"
    if text is not None:
        settings.sensor_file = _file(tmp_path, text)
    with pytest.raises(RuntimeError, match=match):
        bpy.ops.wildscan.scan()
    assert clouds(bpy.context.scene) == []


class _Layout:
    """Records what a panel draws (a background Blender has no UI to draw into)."""

    def __init__(self, drawn: list):
        self.drawn, self.use_property_split, self.use_property_decorate = drawn, True, False
        self.active = self.alert = True

    def prop(self, data, name, **_):
        self.drawn.append(name)

    def column(self, **_):
        return self

    row = box = column

    def label(self, text="", **_):
        self.drawn.append(text)


@pytest.mark.parametrize("device, fields", [("utm30lx-ew", ["device"]), ("FILE", ["device", "sensor_file"])])
def test_the_sensor_panel_draws_the_menu_and_the_file_field_when_chosen(settings, device, fields):
    from types import SimpleNamespace

    from wildscan.ui.panel import VIEW3D_PT_wildscan_sensor

    settings.device = device
    drawn: list[str] = []
    panel = SimpleNamespace(layout=_Layout(drawn))
    context = SimpleNamespace(
        scene=bpy.context.scene, region=SimpleNamespace(width=2000), preferences=bpy.context.preferences
    )
    VIEW3D_PT_wildscan_sensor.draw(panel, context)
    assert drawn[: len(fields)] == fields and "rh" in drawn
    assert ("sensor_file" in drawn) == (device == "FILE")
    # the last line names the device and its beams, or why the sensor file cannot be used
    expected = "Hokuyo UTM-30LX-EW: 194,400 beams" if device != "FILE" else "Sensor file is empty"
    assert expected in drawn[-1]
