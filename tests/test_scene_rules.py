"""Users' own scenes: which objects a scan sees, wrong tags,
a renamed world, and per-object reflectivity. bpy wheel, a few runs of Debian's Blender."""

from __future__ import annotations

import json
import subprocess

import bpy
import numpy as np
import pytest

from wildscan.blender.mesh import GENERATED, mesh_object, wildscan_collection
from wildscan.core.classes import class_by_name
from wildscan.core.errors import UserError
from wildscan.core.world.shapes import primitives
from wildscan.raycast.select import make_backend

from tests.helpers import visibility_probe
from tests.helpers.scene_helpers import BLENDER, REPO, WILDSCAN, fresh_scene, run, user_error_line

BACKENDS = ("embree", "bvh", "blender")
ROCK = class_by_name("rock").id


def _box(name, x, cls="rock", instance=None):
    v, f = primitives.box((x, 0.0, 0.0), (1.0, 1.0, 1.0))
    return mesh_object(name, v, f, wildscan_collection(), cls, instance)


def _down(backend, xs):
    origins = np.array([[x + 0.1, 0.1, 5.0] for x in xs])
    return make_backend(backend, notify=None).cast(origins, np.tile([0.0, 0.0, -1.0], (len(xs), 1)), 10.0)


# -- what exists --------------------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_every_backend_scans_what_the_viewport_shows(backend):
    """Hidden object, hidden and excluded collections, disabled in viewports and zero scale
    are not scanned; hide_render, a tiny scale and a visible instancer's copy are."""
    visibility_probe.build_scene()
    assert visibility_probe.seen_by(backend) == visibility_probe.expected()


@pytest.mark.blender_binary
def test_blender_34_scans_the_same_objects(tmp_path):
    out = tmp_path / "seen.json"
    probe = REPO / "tests" / "helpers" / "visibility_probe.py"
    cmd = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(probe)]
    proc = subprocess.run(
        [*cmd, "--", str(REPO / "addon"), str(out)], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    seen = json.loads(out.read_text())
    assert seen == {"blender": visibility_probe.expected(), "bvh": visibility_probe.expected()}


@pytest.mark.slow
def test_the_addons_display_toggles_do_not_change_what_is_scanned():
    """'Show world', 'In front' and the point size are display only; a scan cloud in the
    scene (loose points) is never scanned."""
    import wildscan
    from wildscan.blender.testworld import build_test_world
    from wildscan.ui.properties import _set_show_world

    fresh_scene()
    wildscan.register()
    try:
        build_test_world(1)
        xs = np.linspace(-20, 20, 41)
        before = {b: _down(b, xs).distance for b in BACKENDS}
        layers = [lc.hide_viewport for lc in bpy.context.view_layer.layer_collection.children]
        settings = bpy.context.scene.wildscan
        _set_show_world(settings, False)
        settings.points_in_front = False
        settings.point_size = 9
        cloud = bpy.data.objects.new("cloud", bpy.data.meshes.new("cloud"))
        cloud.data.from_pydata([(x + 0.1, 0.1, 3.0) for x in xs], [], [])
        cloud["wildscan_cloud"] = True
        bpy.context.scene.collection.objects.link(cloud)
        assert [lc.hide_viewport for lc in bpy.context.view_layer.layer_collection.children] == layers
        for b in BACKENDS:
            np.testing.assert_array_equal(_down(b, xs).distance, before[b])
    finally:
        wildscan.unregister()


# -- wrong tags -----------------------------------------------------------------------------

BAD_TAGS = [
    ("wildscan_class", "rocks"),
    ("wildscan_class", 42),
    ("wildscan_class", ""),
    ("wildscan_instance", "3"),
    ("wildscan_instance", 3.9),
    ("wildscan_instance", -1),
    ("wildscan_instance", 1e10),
    ("wildscan_reflectivity", "shiny"),
    ("wildscan_reflectivity", -5.0),
    ("wildscan_reflectance", 45.0),  # a percent, not 0-1
    ("wildscan_reflectance", "dark"),
]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("key, value", BAD_TAGS)
def test_a_wrong_tag_is_refused_naming_object_value_and_what_is_allowed(backend, key, value):
    fresh_scene()
    _box("good", 0.0, "rock", 1)
    bad = _box("Boulder.003", 40.0, "rock", 2)  # far off: not hit, still refused
    bad[key] = value
    with pytest.raises(UserError) as info:
        _down(backend, [0.0])
    message = str(info.value)
    assert "'Boulder.003'" in message and key in message and repr(value) in message
    if key == "wildscan_class":
        assert "low grass" in message and "rock" in message
    elif key == "wildscan_instance":
        assert "2147483647" in message


@pytest.mark.parametrize("backend", BACKENDS)
def test_documented_variants_of_names_and_whole_floats_are_accepted(backend):
    fresh_scene()
    for k, tag in enumerate(("Rock", "low_grass", "  LOW   grass ", "High-Grass")):
        _box(f"o{k}", 3.0 * k, tag)["wildscan_instance"] = float(k + 1)
    hits = _down(backend, [0.0, 3.0, 6.0, 9.0])
    names = ("rock", "low grass", "low grass", "high grass")
    assert hits.class_id.tolist() == [class_by_name(n).id for n in names]
    assert hits.instance.tolist() == [1, 2, 3, 4]


@pytest.mark.slow
def test_the_command_line_exits_2_on_a_misspelled_tag(tmp_path):
    from wildscan.blender.testworld import build_test_world

    fresh_scene()
    build_test_world(1)
    bpy.data.objects[sorted(o.name for o in bpy.data.objects if o.type == "MESH")[-1]]["wildscan_class"] = (
        "rocks"
    )
    blend = tmp_path / "typo.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), check_existing=False)
    out = tmp_path / "scan.ply"
    proc = run(
        [WILDSCAN, "scan", "--world", str(blend), "--pose", "0", "0", "0", "--rh", "4", "--out", str(out)]
    )
    assert proc.returncode == 2, proc.stderr
    line = user_error_line(proc)
    assert "'rocks'" in line and "wildscan_class" in line and "allowed" in line
    assert not out.exists()


# -- a renamed world -----------------------------------------------------------------------


def _world_objects():
    return sorted(o.name for o in bpy.context.scene.objects if o.get(GENERATED) and o.get("wildscan_class"))


def test_regenerating_replaces_a_renamed_world_and_keeps_the_users_objects():
    from wildscan.blender.replace import replacing_generated
    from wildscan.blender.testworld import build_test_world

    fresh_scene()
    plan = build_test_world(1)
    first = _world_objects()
    assert len(first) == len(plan.elements)
    root = bpy.data.collections["WildScan"]
    root.name = "My forest"
    mine = bpy.data.objects.new("my_rock", bpy.data.meshes.new("my_rock"))
    root.objects.link(mine)
    moved = bpy.data.objects[first[0]]
    own = bpy.data.collections.new("Keep")
    bpy.context.scene.collection.children.link(own)
    own.objects.link(moved)
    root.objects.unlink(moved)

    replacing_generated(lambda: build_test_world(1))

    assert _world_objects() == first  # the same names as a first build: nothing doubled
    assert "My forest" not in bpy.data.collections
    assert mine.name in bpy.data.collections["WildScan"].objects  # the user's object moved along
    assert not own.objects  # WildScan's object the user moved was replaced too


# -- the per-object reflectivity -------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_wildscan_reflectivity_sets_the_intensity_and_keeps_the_label(backend):
    from wildscan.core.scan import measure
    from wildscan.core.sensor import SensorConfig

    fresh_scene()
    _box("plain_rock", 0.0, "rock", 1)
    _box("wet_rock", 3.0, "rock", 2)["wildscan_reflectivity"] = 55.5
    hits = _down(backend, [0.0, 3.0])
    returns = measure(hits, np.zeros(2), SensorConfig(noise_sigma=0.0))
    assert returns.label.tolist() == [ROCK, ROCK]
    assert returns.intensity.tolist() == [40.0, 55.5]


def test_wildscan_reflectance_decides_what_the_realistic_model_loses():
    """Two rock walls 60 m off, one white (0.9) and one black (0.02) by `wildscan_reflectance`:
    the HDL-64E's realistic scan returns the white one and loses the black one (its limit: 10 %
    at 50 m), both keep their class; the paper model returns both."""
    from dataclasses import replace

    from wildscan.core.placement import Pose
    from wildscan.core.realism.lost_returns import object_reflectances
    from wildscan.core.scan import run_scan
    from wildscan.core.sensors import SensorConfig, device_named

    fresh_scene()
    v, f = primitives.box((0.0, 0.0, -0.5), (300.0, 300.0, 1.0))
    mesh_object("ground", v, f, wildscan_collection(), "terrain", 1)
    for name, y, instance, rho in (("white", -6.0, 2, 0.9), ("black", 6.0, 3, 0.02)):
        v, f = primitives.box((60.0, y, 2.0), (1.0, 10.0, 6.0))
        mesh_object(name, v, f, wildscan_collection(), "rock", instance)["wildscan_reflectance"] = rho
    backend = make_backend("embree", notify=None)
    g = backend.geometry
    found = sorted(object_reflectances(g.class_id, g.instance, g.reflectance))
    assert [(c, i) for c, i, _ in found] == [(ROCK, 2), (ROCK, 3)]
    assert [r for _, _, r in found] == pytest.approx([0.9, 0.02])
    sensor = SensorConfig.for_device(device_named("hdl64e"), model="realistic", rh_deg=0.36)
    realistic = run_scan(backend, Pose(0.0, 0.0, 0.0), sensor)
    paper = run_scan(backend, Pose(0.0, 0.0, 0.0), replace(sensor, model="paper"))
    on = realistic.cloud.instance
    assert np.count_nonzero(on == 2) > 50 and np.count_nonzero(on == 3) == 0
    assert set(realistic.cloud.label[np.isin(on, (2, 3))].tolist()) == {ROCK}
    assert np.count_nonzero(paper.cloud.instance == 3) > 50
    lost = realistic.metadata["echoes"]["lost_returns"]["by_class"][str(ROCK)]
    assert lost[1] >= np.count_nonzero(paper.cloud.instance == 3) * 0.9


# -- the Tag section -------------------------------------------------------------------------


def test_the_tag_section_tags_selection_and_collection_with_unique_instances():
    import wildscan
    from wildscan.ui.tag import tag_text, untagged_meshes

    fresh_scene()
    wildscan.register()
    try:
        scene = bpy.context.scene
        tagged = _box("tagged", 0.0, "rock", 5)
        a, b = _box("a", 3.0, None), _box("b", 6.0, None)
        clash = _box("clash", 9.0, None)
        clash["wildscan_instance"] = 5  # the same id as `tagged`: must get its own
        hidden = _box("hidden", 12.0, None)
        hidden.hide_set(True)
        assert [o.name for o in untagged_meshes(scene)] == ["a", "b", "clash"]  # a scan does not see `hidden`

        for obj in (a, b):
            obj.select_set(True)
        assert bpy.ops.wildscan.tag(class_name="bush", target="SELECTED") == {"FINISHED"}
        coll = bpy.data.collections.new("mine")
        scene.collection.children.link(coll)
        coll.objects.link(clash)
        with bpy.context.temp_override(collection=coll):
            assert bpy.ops.wildscan.tag(class_name="low grass", target="COLLECTION") == {"FINISHED"}

        assert (a["wildscan_class"], b["wildscan_class"], clash["wildscan_class"]) == (
            "bush",
            "bush",
            "low grass",
        )
        ids = [o["wildscan_instance"] for o in (tagged, a, b, clash)]
        assert ids[0] == 5 and len(set(ids)) == 4
        assert [o.name for o in untagged_meshes(scene)] == []
        assert tag_text(a).startswith("a: bush, instance ")
        hits = _down("embree", [3.0, 6.0, 9.0])
        assert hits.class_id.tolist() == [class_by_name("bush").id] * 2 + [class_by_name("low grass").id]
    finally:
        wildscan.unregister()


def test_reflectivity_overrides_survive_a_geometry_file(tmp_path):
    from wildscan.raycast.extract import extract_scene
    from wildscan.raycast.scene_file import geometry_file_bytes, load_geometry, save_geometry

    fresh_scene()
    _box("plain_rock", 0.0, "rock", 1)
    plain = extract_scene()
    assert b'"version": 1' in geometry_file_bytes(plain)  # no override: the same file as before
    bpy.data.objects["plain_rock"]["wildscan_reflectivity"] = 12.5
    geometry = extract_scene()
    loaded = load_geometry(save_geometry(geometry, tmp_path / "g.npz"))
    assert loaded.reflectivity.tolist() == [12.5] * loaded.triangle_count


@pytest.mark.parametrize("model", ["paper", "realistic"])
def test_a_whole_scan_with_an_overridden_terrain_keeps_its_labels(model):
    from wildscan.core.placement import Pose
    from wildscan.core.scan import run_scan
    from wildscan.core.sensor import SensorConfig

    fresh_scene()
    v, f = primitives.box((0.0, 0.0, -0.5), (60.0, 60.0, 1.0))
    ground = mesh_object("ground", v, f, wildscan_collection(), "terrain", 1)
    sensor = SensorConfig(rh_deg=10.0, noise_sigma=0.0, model=model)
    before = run_scan(make_backend("embree", notify=None), Pose(0, 0, 0), sensor).cloud
    ground["wildscan_reflectivity"] = 25.0
    after = run_scan(make_backend("embree", notify=None), Pose(0, 0, 0), sensor).cloud
    assert len(after) == len(before) > 100
    np.testing.assert_array_equal(after.label, before.label)
    np.testing.assert_allclose(after.intensity, before.intensity * 0.25, rtol=1e-6)
