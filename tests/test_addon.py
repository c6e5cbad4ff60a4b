"""The Blender add-on's operators, panel logic and packaging on the bpy wheel (headless).

The real-GUI test (Blender 3.4.1 under Xvfb, with a screenshot) is tests/test_gui.py.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import sys
import zipfile

import bpy
import numpy as np
import pytest

import wildscan
from wildscan.app.scan import scan_current_scene
from wildscan.core.classes import COLOR_BY_ID
from wildscan.core.io.ply import read_ply
from wildscan.core.placement import Pose
from wildscan.core.sensors import SensorConfig

from tests.helpers.scene_helpers import CANDIDATE_XY, REPO, WILDSCAN, fresh_scene

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

SEED = 5
RH = 4.0  # 45 2D scans: quick
SETTINGS = dict(rh=RH, min_range=0.2, max_range=14.0, noise=0.02, noise_seed=11)


@pytest.fixture(scope="module", autouse=True)
def addon():
    wildscan.register()
    yield
    wildscan.unregister()


@pytest.fixture
def scene():
    return fresh_scene()


def settings():
    return bpy.context.scene.wildscan


def generate(seed=SEED, detail="low"):
    s = settings()
    s.seed, s.detail, s.world_layout = seed, detail, "paper"  # the paper's island: its zones' poses
    assert bpy.ops.wildscan.generate_world() == {"FINISHED"}


def find_valid_pose(yaw=30.0) -> tuple[float, float, float]:
    """A pose where the live check lets the robot stand (the world may change with the
    generator, so search a few places near the centre)."""
    from wildscan.ui import status

    for x, y in CANDIDATE_XY:
        if status.check_pose(Pose(x, y, yaw), None).ok:
            return x, y, yaw
    raise AssertionError("no valid pose near the world centre")


def use_pose(x, y, yaw):
    s = settings()
    s.pose_x, s.pose_y, s.pose_yaw = x, y, yaw


def configure(frame="leveled", **overrides):
    s = settings()
    for key, value in {**SETTINGS, **overrides}.items():
        setattr(s, key, value)
    s.frame = frame


def sensor_config(**overrides) -> SensorConfig:
    v = {**SETTINGS, **overrides}
    return SensorConfig(
        rh_deg=v["rh"],
        min_range=v["min_range"],
        max_range=v["max_range"],
        noise_sigma=v["noise"],
        noise_seed=v["noise_seed"],
    )


def the_cloud():
    from wildscan.ui.scene import clouds

    found = clouds(bpy.context.scene)
    assert len(found) == 1, [o.name for o in found]
    return found[0]


def snapshot(exclude_generated=True) -> dict:
    """Everything about the scene's objects a scan must not change: names, transforms, data
    (vertex positions), modifiers, custom properties, collections."""
    out = {}
    for obj in bpy.data.objects:
        if exclude_generated and obj.get("wildscan_generated"):
            continue
        entry = {
            "matrix": [round(v, 9) for row in obj.matrix_world for v in row],
            "data": obj.data.name if obj.data is not None else None,
            "modifiers": [
                (m.name, m.type)
                + tuple(
                    sorted(
                        (p.identifier, repr(getattr(m, p.identifier)))
                        for p in m.bl_rna.properties
                        if not p.is_readonly
                        and p.type in {"INT", "FLOAT", "BOOLEAN", "ENUM", "STRING"}
                        and not getattr(p, "is_array", False)
                    )
                )
                for m in obj.modifiers
            ],
            "props": sorted((k, repr(obj[k])) for k in obj.keys()),
            "collections": sorted(c.name for c in obj.users_collection),
            "parent": obj.parent.name if obj.parent else None,
            "hide": (obj.hide_viewport, obj.hide_render),
        }
        if obj.type == "MESH":
            co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
            obj.data.vertices.foreach_get("co", co)
            entry["vertices"] = hashlib.sha1(co.tobytes()).hexdigest()
            entry["polygons"] = len(obj.data.polygons)
        out[obj.name] = entry
    return out


def add_user_objects():
    """Objects of the user's own: a bevelled cube with a custom property, a child empty, and
    a hand-tagged rock far from the poses."""
    from wildscan.blender.mesh import mesh_data

    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(9.0, -9.0, 3.0))
    cube = bpy.context.object
    cube.name = "My cube"
    cube["note"] = "mine"
    cube.modifiers.new("Bevel", "BEVEL").width = 0.1
    empty = bpy.data.objects.new("My empty", None)
    empty.parent = cube
    bpy.context.scene.collection.objects.link(empty)
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float) + [-12.0, 9.0, 2.0]
    mesh = mesh_data("My rock mesh", verts, [[0, 1, 2], [0, 2, 3]])
    del mesh["wildscan_generated"]  # the user made it
    rock = bpy.data.objects.new("My rock", mesh)
    rock["wildscan_class"] = "rock"
    bpy.context.scene.collection.objects.link(rock)
    return cube


# --------------------------------------------------------------------------- registration


def test_register_unregister_register_leaves_exactly_one_of_everything():
    from wildscan.ui import draw

    def our_handlers():
        return [f for f in bpy.app.handlers.depsgraph_update_post if f.__module__.startswith("wildscan.ui")]

    assert hasattr(bpy.types.Scene, "wildscan") and len(our_handlers()) == 1
    wildscan.unregister()
    assert not hasattr(bpy.types.Scene, "wildscan")
    assert not hasattr(bpy.types, "WILDSCAN_OT_scan") and not hasattr(bpy.types, "VIEW3D_PT_wildscan_world")
    assert our_handlers() == [] and draw._state["handle"] is None
    wildscan.register()
    wildscan.unregister()
    wildscan.register()
    assert hasattr(bpy.types.Scene, "wildscan") and len(our_handlers()) == 1
    assert draw._state["handle"] is not None
    for op in ("generate_world", "aerial_view", "scan", "export_scan", "export_ply"):
        assert getattr(bpy.ops.wildscan, op).idname() == f"WILDSCAN_OT_{op}"


def test_settings_survive_disable_and_enable(scene):
    settings().rh = 2.0
    wildscan.unregister()
    wildscan.register()
    assert settings().rh == 2.0


# --------------------------------------------------------------------------- operators


def test_every_operator_runs_headless_on_a_small_world(scene, tmp_path):
    from wildscan.ui.scene import MARKER_PROP, world_info

    generate()
    info = world_info(scene)
    assert info["seed"] == SEED and info["objects"] > 5
    assert bpy.ops.wildscan.aerial_view() == {"FINISHED"}
    marker = settings().marker
    assert marker is not None and marker.get(MARKER_PROP) and marker.empty_display_type == "PLAIN_AXES"
    assert bpy.context.view_layer.objects.active == marker and marker.select_get()  # ready to drag (G)
    area = max((a for a in bpy.context.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    r3d = area.spaces.active.region_3d
    assert r3d.view_perspective == "ORTHO"
    assert np.allclose(tuple(r3d.view_rotation), (1, 0, 0, 0), atol=1e-6)  # looking straight down
    use_pose(*find_valid_pose())
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    cloud = the_cloud()
    assert len(cloud.data.vertices) > 1000 and len(cloud.data.polygons) == 0
    out = tmp_path / "panel.ply"
    assert bpy.ops.wildscan.export_ply(filepath=str(out)) == {"FINISHED"}
    records, comments = read_ply(out)
    assert len(records) == len(cloud.data.vertices)
    assert json.loads(out.with_suffix(".json").read_text())["frame"] == "leveled"


def test_the_pose_settings_move_the_marker_and_read_it_back(scene):
    generate()
    use_pose(1.5, -2.0, 45.0)
    assert bpy.ops.wildscan.add_pose_marker() == {"FINISHED"}
    marker = settings().marker
    assert tuple(marker.location[:2]) == pytest.approx((1.5, -2.0))
    assert math.degrees(marker.rotation_euler[2]) == pytest.approx(45.0)
    marker.location[0] = 3.25  # the user drags the marker
    marker.rotation_euler[2] = math.radians(-90)
    assert settings().pose_x == pytest.approx(3.25) and settings().pose_yaw == pytest.approx(-90.0)
    settings().pose_y = 4.0  # and types a number
    assert marker.location[1] == pytest.approx(4.0)


def test_panel_scan_equals_a_scan_current_scene_with_the_same_settings(scene):
    generate()
    pose = find_valid_pose(yaw=-20.0)
    use_pose(*pose)
    for frame in ("leveled", "sensor", "world"):
        configure(frame=frame)
        assert bpy.ops.wildscan.scan() == {"FINISHED"}
        obj = the_cloud()
        from wildscan.ui.scene import read_cloud

        panel = read_cloud(obj)
        cli = scan_current_scene(Pose(*pose), sensor_config(), frame).cloud
        assert panel.frame == frame and len(panel) == len(cli) > 1000
        assert np.array_equal(panel.to_structured(), cli.to_structured()), frame
        # the viewport shows the points where they are in the world
        world = scan_current_scene(Pose(*pose), sensor_config(), "world").cloud.xyz
        shown = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
        obj.data.vertices.foreach_get("co", shown)
        assert np.abs(shown.reshape(-1, 3) - world).max() < 1e-4


def test_panel_export_equals_the_wildscan_scan_command(scene, tmp_path):
    """The same settings from the panel and from `wildscan scan --seed` give the same PLY records."""
    generate(detail="default")
    pose = find_valid_pose()
    use_pose(*pose)
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    panel_ply = tmp_path / "panel.ply"
    assert bpy.ops.wildscan.export_ply(filepath=str(panel_ply)) == {"FINISHED"}
    cli_ply = tmp_path / "cli.ply"
    s = SETTINGS
    cmd = [
        WILDSCAN,
        "scan",
        "--layout",
        "paper",
        "--seed",
        str(SEED),
        "--pose",
        *map(str, pose),
        "--rh",
        str(s["rh"]),
        "--min-range",
        str(s["min_range"]),
        "--max-range",
        str(s["max_range"]),
        "--noise",
        str(s["noise"]),
        "--noise-seed",
        str(s["noise_seed"]),
        "--quiet",
        "--out",
        str(cli_ply),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    panel_records, _ = read_ply(panel_ply)
    cli_records, _ = read_ply(cli_ply)
    assert len(panel_records) > 1000
    assert np.array_equal(panel_records, cli_records)
    panel_meta = json.loads(panel_ply.with_suffix(".json").read_text())
    cli_meta = json.loads(cli_ply.with_suffix(".json").read_text())
    for key in ("pose", "sensor", "frame", "placement", "seed"):
        assert panel_meta[key] == cli_meta[key], key


def test_export_in_another_frame_moves_the_points_with_the_placement(scene, tmp_path):
    generate()
    pose = find_valid_pose()
    use_pose(*pose)
    configure(frame="leveled", noise=0.0)
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    settings().frame = "sensor"
    out = tmp_path / "sensor.ply"
    assert bpy.ops.wildscan.export_ply(filepath=str(out)) == {"FINISHED"}
    records, _ = read_ply(out)
    expected = scan_current_scene(Pose(*pose), sensor_config(noise=0.0), "sensor").cloud
    got = np.column_stack([records["x"], records["y"], records["z"]])
    assert np.abs(got - expected.xyz).max() < 1e-5
    assert np.array_equal(records["label"], expected.label)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["frame"] == "sensor" and meta["converted_from_frame"] == "leveled"


def test_a_cloud_survives_save_and_reload(scene, tmp_path):
    generate()
    use_pose(*find_valid_pose())
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    before = tmp_path / "before.ply"
    assert bpy.ops.wildscan.export_ply(filepath=str(before)) == {"FINISHED"}
    blend = tmp_path / "scan.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    fresh_scene()
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    after = tmp_path / "after.ply"
    assert bpy.ops.wildscan.export_ply(filepath=str(after)) == {"FINISHED"}
    assert np.array_equal(read_ply(before)[0], read_ply(after)[0])


def test_the_cloud_is_one_object_in_class_colours_that_the_next_scan_replaces(scene):
    from wildscan.ui import draw

    generate()
    use_pose(*find_valid_pose())
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    first = the_cloud()
    counts = {int(k): v for k, v in first["wildscan_class_counts"].items()}
    pos, rgba = draw.cloud_arrays(first)
    labels = np.array([int(k) for k, v in counts.items() for _ in range(v)])
    assert len(pos) == sum(counts.values()) and len(counts) >= 3
    assert sorted(map(tuple, np.unique((rgba[:, :3] * 255).round().astype(int), axis=0))) == sorted(
        map(tuple, COLOR_BY_ID[np.unique(labels)].astype(int))
    )
    first_name = first.name
    settings().noise_seed += 1
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    second = the_cloud()  # the first one is gone, its name reused
    assert second.name == first_name and second["wildscan_scan_number"] == 2
    settings().keep_previous = True
    settings().noise_seed += 1
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    from wildscan.ui.scene import clouds

    assert len(clouds(bpy.context.scene)) == 2


def test_scan_progress_reaches_the_end(scene, monkeypatch):
    from wildscan.ui import feedback

    seen = []
    original = feedback.Progress.fraction
    monkeypatch.setattr(
        feedback.Progress, "fraction", lambda self, v, text=None: (seen.append(v), original(self, v, text))
    )
    generate()
    assert len(seen) >= 2 and seen == sorted(seen) and seen[-1] < 1.0  # world stages
    seen.clear()
    use_pose(*find_valid_pose())
    configure(rh=1.0)  # 194,400 beams: several progress chunks
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    assert len(seen) >= 3 and seen == sorted(seen) and seen[-1] == 1.0


# --------------------------------------------------------------------------- nothing else changes


def test_operators_never_alter_objects_they_did_not_create(scene, tmp_path):
    add_user_objects()
    generate()
    use_pose(*find_valid_pose())
    configure()
    before = snapshot()
    world_before = {o.name for o in bpy.data.objects if o.get("wildscan_generated")}
    assert bpy.ops.wildscan.aerial_view() == {"FINISHED"}
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    assert bpy.ops.wildscan.export_ply(filepath=str(tmp_path / "s.ply")) == {"FINISHED"}
    settings().pose_x += 0.5
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    assert snapshot() == before
    # the world (WildScan's own objects) is untouched by scans too
    world_now = {o.name for o in bpy.data.objects if o.get("wildscan_generated")}
    assert world_before <= world_now and len(world_now - world_before) == 3  # marker, heading, one cloud
    # generating again replaces the world under the same names and keeps the user's objects
    assert bpy.ops.wildscan.generate_world() == {"FINISHED"}
    assert snapshot() == before
    assert {o.name for o in bpy.data.objects if o.get("wildscan_generated")} == world_now


# --------------------------------------------------------------------------- mistakes


def assert_rejected(op, match, **kwargs):
    before = snapshot(exclude_generated=False)
    with pytest.raises(RuntimeError, match=match):
        op(**kwargs)
    assert snapshot(exclude_generated=False) == before


def test_invalid_poses_give_a_report_naming_the_problem_and_change_nothing(scene):
    from wildscan.ui import status

    add_user_objects()
    generate()
    use_pose(*find_valid_pose())
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}  # a cloud exists: a failed scan must keep it
    use_pose(500.0, 500.0, 0.0)
    assert_rejected(bpy.ops.wildscan.scan, "off the world")
    # a tagged rock of the user's under the footprint: the report names the laser and the rock
    x, y, yaw = find_valid_pose(yaw=0.0)
    from wildscan.blender.mesh import mesh_data

    rock = bpy.data.objects.new("Boulder", mesh_data("Boulder", *box_under_front_laser(x, y)))
    rock["wildscan_class"] = "rock"
    bpy.context.scene.collection.objects.link(rock)
    use_pose(x, y, 0.0)
    assert_rejected(bpy.ops.wildscan.scan, r"laser front \(\+X\) hit rock")
    live = status.pose_status(bpy.context.scene)
    assert not live.ok and "front (+X) hit rock" in live.text


def box_under_front_laser(x, y):
    """A box around the ground under the front laser of a yaw-0 pose at (x, y), reaching less
    high than where the placement lasers start."""
    from wildscan.app.scan import make_scene_backend
    from wildscan.core.placement import ARM_X, LASER_CLEARANCE, place
    from wildscan.core.world.shapes.primitives import box

    pose = Pose(x, y, 0.0)
    ground = place(make_scene_backend("blender", pose, SensorConfig(), notify=None), pose).lasers[0].hit_z
    return box((x + ARM_X, y, ground), (0.3, 0.3, LASER_CLEARANCE))


@pytest.mark.parametrize(
    "changes, match",
    [
        (dict(rh=0.7), "r_h must divide 180"),
        (dict(min_range=5.0, max_range=4.0), r"Min range \(5 m\) must be below Max range"),
        (dict(max_range=40.0), "Max range must be in"),
        (dict(noise=-0.1), "Noise must be from 0"),
    ],
)
def test_invalid_settings_give_a_report_naming_the_problem_and_change_nothing(scene, changes, match):
    generate()
    use_pose(*find_valid_pose())
    configure(**changes)
    assert_rejected(bpy.ops.wildscan.scan, match)


def test_the_weather_fields_scan_as_scan_current_scene_in_that_weather(scene):
    from wildscan.core.classes import PARTICLE_ID
    from wildscan.core.effects.weather import KEYS
    from wildscan.ui.scene import read_cloud

    weather = settings().weather
    for key, (_, _, _, high) in KEYS.items():  # the command line's limits are the fields' range
        assert weather.bl_rna.properties[key].soft_max == high and getattr(weather, key) == 0.0
    generate()
    pose = find_valid_pose()
    use_pose(*pose)
    configure()
    weather.rain, weather.fog = 100.0, 60.0
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    panel = read_cloud(the_cloud())
    cli = scan_current_scene(Pose(*pose), sensor_config(), "leveled", weather=dict(rain=100, fog=60)).cloud
    assert (panel.label == PARTICLE_ID).sum() > 100
    assert np.array_equal(panel.to_structured(), cli.to_structured())
    assert np.array_equal(panel.extra["weather"], cli.extra["weather"])


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("rain", 600.0, "--weather rain='600' is out of range; rain is 0 to 500 mm/h"),
        ("fog", 2.0, "--weather fog='2' is out of range; fog is 0 (none) or 5 to 100000 m of visibility"),
        ("snow", -1.0, "--weather snow='-1' is out of range; snow is 0 to 100 mm/h of melted snow"),
    ],
)
def test_a_weather_field_out_of_range_gets_the_command_lines_message(scene, key, value, message):
    import re

    from wildscan.app.settings import command_line_message
    from wildscan.core.effects.weather import parse_settings
    from wildscan.core.errors import UserError

    with pytest.raises(UserError) as cli:
        parse_settings(f"{key}={value:g}")
    assert command_line_message(cli.value) == message
    generate()
    use_pose(*find_valid_pose())
    configure()
    setattr(settings().weather, key, value)
    assert_rejected(bpy.ops.wildscan.scan, re.escape(message.replace("--weather", "Weather")) + "$")


def test_export_mistakes_are_reports(scene, tmp_path):
    generate()
    assert_rejected(bpy.ops.wildscan.export_ply, "No scan to export", filepath=str(tmp_path / "x.ply"))
    use_pose(*find_valid_pose())
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    assert_rejected(bpy.ops.wildscan.export_ply, "does not exist", filepath=str(tmp_path / "no" / "x.ply"))
    assert_rejected(bpy.ops.wildscan.export_ply, "must end in .ply", filepath=str(tmp_path / "x.txt"))
    # a too-long name is a user message, not an internal-error report
    assert_rejected(bpy.ops.wildscan.export_ply, "longer than", filepath=str(tmp_path / ("x" * 300 + ".ply")))
    assert not any(tmp_path.iterdir())


def test_export_writes_every_format_of_the_table_with_the_same_points(scene, tmp_path):
    """The add-on's export goes through the format table (core/io/formats.py) like `wildscan scan`."""
    import laspy

    generate()
    use_pose(*find_valid_pose())
    configure()
    assert bpy.ops.wildscan.scan() == {"FINISHED"}
    ply = tmp_path / "s.ply"
    assert bpy.ops.wildscan.export_scan(filepath=str(ply), format="ply") == {"FINISHED"}
    assert bpy.ops.wildscan.export_scan(filepath=str(tmp_path / "s.las"), format="las") == {"FINISHED"}
    assert bpy.ops.wildscan.export_scan(filepath=str(tmp_path / "k.bin"), format="semantickitti") == {
        "FINISHED"
    }
    records, _ = read_ply(ply)
    las = laspy.read(tmp_path / "s.las")
    assert np.array_equal(np.asarray(las.wildscan_label), records["label"])
    assert np.allclose(las.x, records["x"], atol=las.header.scales[0])
    velodyne = np.fromfile(tmp_path / "k.bin", dtype="<f4").reshape(-1, 4)
    assert np.array_equal(velodyne[:, 2], records["z"])
    assert (tmp_path / "k.label").stat().st_size == 4 * len(records)
    assert_rejected(
        bpy.ops.wildscan.export_scan, "must end in .las", filepath=str(tmp_path / "x.ply"), format="las"
    )
    assert_rejected(
        bpy.ops.wildscan.export_scan, "ply only", filepath=str(tmp_path / "x.las"), format="las", ascii=True
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["k.bin", "k.label", "s.json", "s.las", "s.ply"]


def test_aerial_view_without_a_world_is_a_report(scene):
    assert_rejected(bpy.ops.wildscan.aerial_view, "generate a world first")


def test_a_failed_generate_leaves_the_previous_world_as_it_was(scene, monkeypatch):
    import wildscan.blender.builder as builder_module
    from wildscan.blender.testworld import build_test_world
    from wildscan.core.errors import UserError

    add_user_objects()
    generate()
    coll = bpy.data.collections["WildScan"]
    mine = bpy.data.objects.new("Mine inside the world collection", None)
    coll.objects.link(mine)
    before = snapshot(exclude_generated=False)

    def half_then_crash(seed, detail="default", progress=None, **kw):
        build_test_world(seed + 1)  # builds a whole other world...
        raise MemoryError("out of memory")  # ...and then fails

    monkeypatch.setattr(builder_module, "build_world", half_then_crash)
    with pytest.raises(RuntimeError, match="could not finish building the world.*MemoryError"):
        bpy.ops.wildscan.generate_world()
    assert snapshot(exclude_generated=False) == before

    def user_mistake(seed, detail="default", progress=None, **kw):
        raise UserError("must be one of low, default, high", setting="detail")

    monkeypatch.setattr(builder_module, "build_world", user_mistake)
    with pytest.raises(RuntimeError, match="Detail must be one of"):
        bpy.ops.wildscan.generate_world()
    assert snapshot(exclude_generated=False) == before


# --------------------------------------------------------------------------- frames (numpy)


def test_frame_conversions_round_trip_and_match_the_placement():
    from wildscan.core.spatial import frames

    placement = {
        "pose": {"yaw_deg": 37.0},
        "roll_deg": 4.0,
        "pitch_deg": -6.0,
        "optical_centre": [3.0, -2.0, 1.7],
    }
    pts = np.random.default_rng(0).normal(size=(50, 3)) * 5
    for frame in ("leveled", "sensor", "world"):
        back = frames.from_world(frames.to_world(pts, frame, placement), frame, placement)
        assert np.abs(back - pts).max() < 1e-12
    # leveled = Rz(-yaw)·(world - c) (docs/architecture.md "Frames")
    world = frames.to_world(pts, "leveled", placement)
    yaw = math.radians(37.0)
    rz = np.array([[math.cos(-yaw), -math.sin(-yaw), 0], [math.sin(-yaw), math.cos(-yaw), 0], [0, 0, 1]])
    assert np.abs((world - placement["optical_centre"]) @ rz.T - pts).max() < 1e-12


# --------------------------------------------------------------------------- packaging


@pytest.fixture(scope="module")
def zips(tmp_path_factory):
    sys.path.insert(0, str(REPO / "tools"))
    try:
        import build_addon
    finally:
        sys.path.pop(0)
    return build_addon.build(tmp_path_factory.mktemp("dist"))


def test_the_zips_have_the_layouts_blender_installs(zips):
    legacy, extension = zips
    version = wildscan.__version__
    assert (
        legacy.name == f"wildscan-{version}-legacy.zip"
        and extension.name == f"wildscan-{version}-extension.zip"
    )
    with zipfile.ZipFile(legacy) as z:
        names = z.namelist()
        assert "wildscan/__init__.py" in names and "wildscan/ui/operators.py" in names
        assert all(n.startswith("wildscan/") for n in names)
        assert "bl_info" in z.read("wildscan/__init__.py").decode()
        assert not any(n.endswith("blender_manifest.toml") or "__pycache__" in n for n in names)
    with zipfile.ZipFile(extension) as z:
        names = z.namelist()
        assert "blender_manifest.toml" in names and "__init__.py" in names and "ui/panel.py" in names
        assert not any(n.startswith("wildscan/") or "__pycache__" in n for n in names)


INSTALL_SCRIPT = """
import sys
kind, zip_path, user_dir, repo_addon = sys.argv[1:5]
# The package is also installed editable (repo/addon on sys.path): hide that copy so the one
# Blender installs from the zip is the one that runs.
sys.path[:] = [p for p in sys.path if p.rstrip("/") != repo_addon]
import bpy, addon_utils
bpy.ops.wm.read_factory_settings(use_empty=True)
if kind == "extension":
    assert bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                    enable_on_install=True) == {"FINISHED"}
    module = sys.modules["bl_ext.user_default.wildscan"]
else:
    assert bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True) == {"FINISHED"}
    module = addon_utils.enable("wildscan", default_set=True, handle_error=None)
assert module.__file__.startswith(user_dir), module.__file__
s = bpy.context.scene.wildscan
s.seed, s.rh, s.detail, s.world_layout = 3, 6.0, "low", "paper"
assert bpy.ops.wildscan.generate_world() == {"FINISHED"}
check = module.ui.status.check_pose
Pose = module.core.placement.Pose
s.pose_x, s.pose_y = next((x, y) for x, y in CANDIDATES if check(Pose(x, y, 0.0), None).ok)
assert bpy.ops.wildscan.scan() == {"FINISHED"}
print("INSTALLED-OK", len([o for o in bpy.data.objects if o.get("wildscan_cloud")]))
"""


@pytest.mark.parametrize("kind", ["legacy", "extension"])
def test_each_zip_installs_and_runs_in_blender_5(zips, tmp_path, kind):
    """Install the zip the way Blender 5.0 does (Install from Disk / legacy add-on install,
    into temporary user directories), then generate and scan through the installed copy."""
    legacy, extension = zips
    user = tmp_path / "user"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), BLENDER_USER_SCRIPTS=str(user / "scripts"))
    script = f"CANDIDATES = {CANDIDATE_XY!r}\n" + INSTALL_SCRIPT
    zip_path = extension if kind == "extension" else legacy
    run = subprocess.run(
        [sys.executable, "-c", script, kind, str(zip_path), str(user), str(REPO / "addon")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        cwd=tmp_path,
    )
    assert "INSTALLED-OK 1" in run.stdout, run.stdout[-2000:] + run.stderr[-2000:]
