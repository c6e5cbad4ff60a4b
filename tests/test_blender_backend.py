"""The reference ray backend (Scene.ray_cast), on the bpy wheel and on Debian's Blender 3.4."""

from __future__ import annotations

import json
import runpy
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import bpy
import numpy as np
import pytest

from wildscan.blender.mesh import mesh_object, wildscan_collection
from wildscan.core.classes import WATER_ID, class_by_name
from wildscan.core.hits import MISS_CLASS, MISS_INSTANCE
from wildscan.core.world.shapes import primitives
from wildscan.raycast.blender_backend import BlenderRayCastBackend

ADDON_DIR = Path(__file__).resolve().parents[1] / "addon"
ROCK = class_by_name("rock").id


@pytest.fixture(autouse=True)
def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield bpy.context.scene


def _box(name, center, size, cls=None, instance=None):
    v, f = primitives.box(center, size)
    return mesh_object(name, v, f, wildscan_collection(), cls, instance)


def _cast(origins, directions, max_range=100.0, **kw):
    return BlenderRayCastBackend().cast(
        np.asarray(origins, float), np.asarray(directions, float), max_range, **kw
    )


def test_hit_on_a_box_gives_the_exact_distance_class_and_instance():
    _box("rock", (0, 0, 0), (2, 2, 2), "rock", 5)
    hits = _cast([-10.0, 0.3, 0.2], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert hits.distance[0] == pytest.approx(9.0, abs=1e-6)
    assert hits.class_id[0] == ROCK and hits.instance[0] == 5
    assert hits.distance[1] == np.inf and hits.class_id[1] == MISS_CLASS and hits.instance[1] == MISS_INSTANCE
    assert hits.class_id.dtype == np.int16 and hits.instance.dtype == np.int32
    assert hits.untagged_objects == frozenset()


def test_a_slanted_ray_to_a_moved_object_is_measured_in_world_space():
    obj = _box("rock", (0, 0, 0), (2, 2, 2), "rock", 1)
    obj.location = (0.0, 0.0, 5.0)
    d = np.array([3.0, 0.0, 4.0]) / 5.0
    hits = _cast([-3.5, 0.0, 0.0], [d])  # meets the box bottom (z = 4) at x = -0.5, after 5 m
    assert hits.distance[0] == pytest.approx(5.0, abs=1e-5)


def test_miss_everything_and_empty_input():
    hits = _cast([0.0, 0.0, 0.0], [[0.0, 0.0, 1.0]])
    assert not hits.hit.any() and hits.class_id[0] == -1 and hits.instance[0] == -1
    empty = _cast([0.0, 0.0, 0.0], np.zeros((0, 3)))
    assert len(empty.distance) == 0


def test_hits_beyond_max_range_are_misses():
    _box("rock", (0, 0, 0), (2, 2, 2), "rock", 5)
    o, d = [-10.0, 0.0, 0.0], [[1.0, 0.0, 0.0]]
    assert not _cast(o, d, max_range=8.9).hit[0]
    assert _cast(o, d, max_range=9.1).distance[0] == pytest.approx(9.0, abs=1e-6)


def test_water_is_reported_as_water():
    v, f = primitives.disc(3.0, -0.5)
    mesh_object("pond", v, f, wildscan_collection(), "water", 2)
    hits = _cast([0.5, 0.5, 2.0], [[0.0, 0.0, -1.0]])
    assert hits.class_id[0] == WATER_ID and hits.instance[0] == 2
    assert hits.distance[0] == pytest.approx(2.5, abs=1e-6)


def test_untagged_objects_are_unlabeled_and_named():
    _box("tagged", (0, 0, 0), (1, 1, 1), "rock", 3)
    _box("users_own", (0, 5, 0), (1, 1, 1))
    _box("numbered", (0, 10, 0), (1, 1, 1), None, 4)
    dirs = np.array([[1.0, 0.0, 0.0]] * 3)
    origins = np.array([[-5.0, 0.0, 0.0], [-5.0, 5.0, 0.0], [-5.0, 10.0, 0.0]])
    hits = _cast(origins, dirs)
    assert hits.class_id.tolist() == [ROCK, 0, 0]
    assert hits.instance.tolist() == [3, 0, 4]
    assert hits.untagged_objects == frozenset({"users_own", "numbered"})
    # an unknown class is a mistake, not "untagged": tests/test_scene_rules.py


def test_many_origins_straight_down_onto_a_plane():
    v, f = primitives.grid_heightfield(np.linspace(-10, 10, 3), np.linspace(-10, 10, 3), np.zeros((3, 3)))
    mesh_object("ground", v, f, wildscan_collection(), "terrain", 1)
    rng = np.random.default_rng(1)
    origins = np.column_stack([rng.uniform(-9, 9, (500, 2)), rng.uniform(0.5, 20, 500)])
    dirs = np.broadcast_to([0.0, 0.0, -1.0], origins.shape)
    hits = _cast(origins, dirs, max_range=25.0)
    np.testing.assert_allclose(hits.distance, origins[:, 2], atol=1e-5)
    assert (hits.class_id == 1).all() and (hits.instance == 1).all()


def test_tags_come_from_the_original_object_under_a_modifier():
    obj = _box("rock", (0, 0, 0), (1, 1, 1), "rock", 7)
    mod = obj.modifiers.new("copies", "ARRAY")
    mod.count = 3
    mod.use_relative_offset = False
    mod.use_constant_offset = True
    mod.constant_offset_displace = (0.0, 4.0, 0.0)
    # only the evaluated mesh has the third copy, at y = 8
    hits = _cast([-5.0, 8.0, 0.0], [[1.0, 0.0, 0.0]])
    assert hits.distance[0] == pytest.approx(4.5, abs=1e-6)
    assert hits.class_id[0] == ROCK and hits.instance[0] == 7


def test_instanced_copies_take_the_instancers_tags_and_the_template_its_own():
    # the template rock (class only) is in the scene itself and instanced by two empties
    # that carry instance ids: each copy gets its instancer's id, the template none
    template = _box("template", (0, 0, 0), (1, 1, 1), "rock", None)
    source = bpy.data.collections.new("templates")
    source.objects.link(template)
    for i, x in enumerate((5.0, 10.0)):
        empty = bpy.data.objects.new(f"instancer {i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = source
        empty.location = (x, 0.0, 0.0)
        empty["wildscan_instance"] = 21 + i
        empty["wildscan_class"] = "bush"  # the template's own class wins, as in extract.py
        bpy.context.scene.collection.objects.link(empty)
    origins = np.array([[0.0, 0.0, 5.0], [5.0, 0.0, 5.0], [10.0, 0.0, 5.0], [10.0, 0.0, 5.0]])
    hits = _cast(origins, np.tile([0.0, 0.0, -1.0], (4, 1)))
    assert hits.class_id.tolist() == [ROCK] * 4
    assert hits.instance.tolist() == [0, 21, 22, 22]
    np.testing.assert_allclose(hits.distance, 4.5, atol=1e-6)


def test_a_scene_outside_any_window_is_cast_in_its_own_depsgraph():
    other = bpy.data.scenes.new("not shown")
    v, f = primitives.box((0, 0, 0), (2, 2, 2))
    obj = bpy.data.objects.new("far rock", bpy.data.meshes.new("far rock"))
    obj.data.from_pydata(v.tolist(), [], f.tolist())
    obj["wildscan_class"], obj["wildscan_instance"] = "rock", 8
    other.collection.objects.link(obj)
    assert other.view_layers[0].depsgraph is None  # what broke the backend before
    hits = BlenderRayCastBackend(scene=other).cast(
        np.array([-10.0, 0.0, 0.0]), np.array([[1.0, 0.0, 0.0]]), 20.0
    )
    assert hits.distance[0] == pytest.approx(9.0, abs=1e-6) and hits.instance[0] == 8
    # the active scene is empty: the backend did not look there
    assert not _cast([-10.0, 0.0, 0.0], [[1.0, 0.0, 0.0]]).hit[0]


def test_sees_objects_added_after_the_backend_was_made():
    backend = BlenderRayCastBackend()
    _box("late", (0, 0, 0), (2, 2, 2), "bush", 9)
    hits = backend.cast(np.array([-5.0, 0.0, 0.0]), np.array([[1.0, 0.0, 0.0]]), 10.0)
    assert hits.distance[0] == pytest.approx(4.0, abs=1e-6) and hits.instance[0] == 9


def test_progress_is_reported_every_ten_thousand_rays():
    calls = []
    dirs = np.tile([0.0, 0.0, 1.0], (25_000, 1))
    _cast([0.0, 0.0, 0.0], dirs, progress=lambda done, total: calls.append((done, total)))
    assert calls == [(10_000, 25_000), (20_000, 25_000), (25_000, 25_000)]


def test_mismatched_origins_are_refused():
    with pytest.raises(ValueError):
        _cast(np.zeros((2, 3)), np.tile([1.0, 0.0, 0.0], (3, 1)))


# --- the same script on the bpy wheel and on Debian's Blender 3.4 -----------------

PROBE = textwrap.dedent(
    '''
    """Build the test world, cast a fixed fan of rays, dump the hits as JSON."""
    import json
    import sys
    import time


    def probe_rays(plan):
        import numpy as np

        az = np.radians(np.arange(0.0, 360.0, 3.0))
        el = np.radians(np.arange(-40.0, 40.0, 1.0))
        a, e = np.meshgrid(az, el)
        fan = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1).reshape(-1, 3)
        eye = np.array([0.0, 0.0, plan.height_at(0.0, 0.0) + 1.0])
        xy = np.random.default_rng(11).uniform(-29.0, 29.0, (400, 2))
        down = np.column_stack([xy, np.full(len(xy), 20.0)])
        origins = np.concatenate([np.broadcast_to(eye, fan.shape), down])
        dirs = np.concatenate([fan, np.broadcast_to([0.0, 0.0, -1.0], down.shape)])
        return origins, dirs


    def main(addon_dir, out_path, seed):
        sys.path.insert(0, addon_dir)
        import bpy

        from wildscan.raycast.blender_backend import BlenderRayCastBackend
        from wildscan.blender.testworld import build_test_world

        bpy.ops.wm.read_factory_settings(use_empty=True)
        t0 = time.perf_counter()
        plan = build_test_world(seed)
        build_s = time.perf_counter() - t0
        origins, dirs = probe_rays(plan)
        backend = BlenderRayCastBackend()
        t0 = time.perf_counter()
        hits = backend.cast(origins, dirs, 40.0)
        cast_s = time.perf_counter() - t0
        with open(out_path, "w") as fh:
            json.dump(
                {
                    "version": list(bpy.app.version),
                    "build_s": build_s,
                    "us_per_ray": cast_s / len(dirs) * 1e6,
                    "n_objects": len(bpy.data.objects),
                    "distance": hits.distance.tolist(),
                    "class_id": hits.class_id.tolist(),
                    "instance": hits.instance.tolist(),
                    "untagged": sorted(hits.untagged_objects),
                },
                fh,
            )


    if __name__ == "__main__":
        args = sys.argv[sys.argv.index("--") + 1:]
        main(args[0], args[1], int(args[2]))
    '''
)


def _blender34() -> str:
    exe = shutil.which("blender")
    assert exe, "Debian's blender (apt package `blender`) is needed for this test"
    return exe


@pytest.mark.blender_binary
def test_blender_34_gives_the_same_hits_as_the_wheel(tmp_path):
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    wheel_out, old_out = tmp_path / "wheel.json", tmp_path / "b34.json"
    seed = 4

    runpy.run_path(str(script), run_name="probe")["main"](str(ADDON_DIR), str(wheel_out), seed)
    cmd = [
        _blender34(),
        "-b",
        "--factory-startup",
        "--python-exit-code",
        "1",
        "-P",
        str(script),
        "--",
        str(ADDON_DIR),
        str(old_out),
        str(seed),
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]

    wheel, old = json.loads(wheel_out.read_text()), json.loads(old_out.read_text())
    assert wheel["version"][0] >= 4 and old["version"][:2] == [3, 4]
    assert wheel["n_objects"] == old["n_objects"]
    d_wheel, d_old = np.array(wheel["distance"]), np.array(old["distance"])
    assert np.isfinite(d_wheel).sum() > 0.5 * len(d_wheel)
    assert np.array_equal(np.isfinite(d_wheel), np.isfinite(d_old))
    hit = np.isfinite(d_wheel)
    np.testing.assert_allclose(d_old[hit], d_wheel[hit], rtol=0, atol=1e-6)
    assert wheel["class_id"] == old["class_id"] and wheel["instance"] == old["instance"]
    assert len(set(wheel["class_id"])) >= 12  # the fan from the origin sees most classes
    print(
        f"\nwheel {wheel['version']}: build {wheel['build_s'] * 1e3:.0f} ms, "
        f"{wheel['us_per_ray']:.2f} us/ray; "
        f"blender {old['version']}: build {old['build_s'] * 1e3:.0f} ms, {old['us_per_ray']:.2f} us/ray",
        file=sys.stderr,
    )
