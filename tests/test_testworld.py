"""The test world: numpy plan (primitives, layout, terrain) and its Blender build."""

from __future__ import annotations

import bpy
import numpy as np
import pytest

from wildscan.blender.mesh import mesh_object, remove_generated, wildscan_collection
from wildscan.blender.testworld import build_test_world
from wildscan.core.classes import TAG_NAMES
from wildscan.core.world import testworld as tw
from wildscan.core.world.shapes import primitives
from wildscan.core.world.shapes.powerline import catenary_points
from wildscan.raycast.blender_backend import BlenderRayCastBackend

REQUIRED = {
    "terrain",
    "water",
    "trunk",
    "treetop",
    "rock",
    "table",
    "bench",
    "fence",
    "bush",
    "low grass",
    "high grass",
    "pole",
    "wire",
}
SEEDS = (0, 1, 7, 12345)


@pytest.fixture
def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield bpy.context.scene


@pytest.fixture(scope="module")
def plans():
    return {s: tw.plan_test_world(s) for s in SEEDS}


# --- primitives ------------------------------------------------------------


def _is_closed_and_consistent(faces: np.ndarray) -> bool:
    """Every edge used by exactly two faces, in opposite directions."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    undirected, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    return bool((counts == 2).all()) and len(np.unique(directed, axis=0)) == len(directed)


@pytest.mark.parametrize(
    "mesh, volume, rel",
    [
        (primitives.box((1, 2, 3), (1, 2, 3)), 6.0, 1e-12),
        (primitives.cylinder(1.0, 2.0, 64, (5, 0, 0)), 2 * np.pi, 0.01),
        (primitives.cone(1.0, 3.0, 64), np.pi, 0.01),
        (primitives.uv_sphere(1.0, 32, 64), 4 / 3 * np.pi, 0.01),
        (primitives.beam((0, 0, 0), (3, 0, 1), 0.1), 0.01 * np.sqrt(10), 1e-9),
        (primitives.tube([(0, 0, 0), (0, 0, 1), (0, 1, 2)], 0.1, 32), None, None),
    ],
)
def test_primitives_are_closed_outward_and_the_right_size(mesh, volume, rel):
    v, f = mesh
    assert f.dtype == np.int32 and f.shape[1] == 3 and f.min() >= 0 and f.max() < len(v)
    assert _is_closed_and_consistent(f)
    vol = primitives.signed_volume(v, f)
    assert vol > 0
    if volume is not None:
        assert vol == pytest.approx(volume, rel=rel)


def test_box_spans_its_size():
    v, _ = primitives.box((1, 2, 3), (2, 4, 6))
    assert v.min(axis=0).tolist() == [0, 0, 0] and v.max(axis=0).tolist() == [2, 4, 6]


def test_grid_heightfield_faces_point_up_and_cover_the_grid():
    xs, ys = np.linspace(0, 2, 3), np.linspace(0, 1, 2)
    v, f = primitives.grid_heightfield(xs, ys, np.zeros((2, 3)))
    assert len(v) == 6 and len(f) == 4
    tri = v[f]
    normals_z = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
    assert (normals_z > 0).all()
    assert normals_z.sum() / 2 == pytest.approx(2.0)  # total area


def test_the_wires_catenary_hangs_between_its_ends():
    p0, p1 = (0.0, 0.0, 6.0), (8.0, 0.0, 5.5)
    # the test world's wire takes its parameter from the parabola a = L^2 / (8 sag)
    path = catenary_points(p0, p1, 8.0**2 / (8 * 1.0), 101)
    assert np.allclose(path[0], p0) and np.allclose(path[-1], p1)
    mid_chord = (p0[2] + p1[2]) / 2
    assert mid_chord - path[50, 2] == pytest.approx(1.0, abs=0.1)
    assert path[:, 2].min() < min(p0[2], p1[2])


# --- plan ------------------------------------------------------------------


def test_plan_is_deterministic_per_seed(plans):
    again = tw.plan_test_world(1)
    first = plans[1]
    assert [e.name for e in again.elements] == [e.name for e in first.elements]
    for a, b in zip(again.elements, first.elements):
        assert np.array_equal(again.element_vertices(a), first.element_vertices(b))
        assert np.array_equal(again.prototypes[a.proto].faces, first.prototypes[b.proto].faces)
    assert np.array_equal(again.heights, first.heights)
    other = plans[7]
    assert not np.array_equal(other.heights, first.heights)
    rock = [e for e in first.elements if e.name == "rock_1"][0]
    other_rock = [e for e in other.elements if e.name == "rock_1"][0]
    assert not np.allclose(first.element_vertices(rock), other.element_vertices(other_rock))


@pytest.mark.parametrize("seed", SEEDS)
def test_plan_has_every_class_and_unique_instances(plans, seed):
    plan = plans[seed]
    assert plan.classes == REQUIRED
    assert plan.classes <= set(TAG_NAMES)
    instances = [e.instance for e in plan.elements]
    assert len(set(instances)) == len(instances) and min(instances) >= 1
    assert len(plan.elements_of("pole")) == 2 and len(plan.elements_of("wire")) == 1


@pytest.mark.parametrize("seed", SEEDS)
def test_layout_keeps_the_clear_zone_and_stays_near_the_origin(plans, seed):
    plan = plans[seed]
    for el in plan.elements:
        if el.wildscan_class in ("terrain", "water"):
            continue
        v = plan.element_vertices(el)
        r = np.hypot(v[:, 0], v[:, 1])
        assert r.min() >= tw.CLEAR_RADIUS, el.name
        assert r.max() <= 15.5, el.name
        pond = np.hypot(v[:, 0] - plan.pond_center[0], v[:, 1] - plan.pond_center[1])
        assert pond.min() > plan.pond_radius, el.name


@pytest.mark.parametrize("seed", SEEDS)
def test_elements_stand_on_the_terrain(plans, seed):
    plan = plans[seed]
    for el in plan.elements:
        if el.wildscan_class in ("terrain", "water", "treetop", "wire"):
            continue
        v = plan.element_vertices(el)
        above = v[:, 2] - plan.height_at(v[:, 0], v[:, 1])
        assert -1.0 < above.min() <= 0.0, el.name  # touches the ground, not buried
        assert above.max() > 0.05, el.name  # and shows above it


@pytest.mark.parametrize("seed", SEEDS)
def test_wire_sags_between_the_pole_tops_well_above_ground(plans, seed):
    plan = plans[seed]
    wire = plan.element_vertices(plan.elements_of("wire")[0])
    clearance = wire[:, 2] - plan.height_at(wire[:, 0], wire[:, 1])
    assert 3.0 < clearance.min() < 5.0
    for pole in plan.elements_of("pole"):
        x, y = plan.element_vertices(pole)[:, :2].mean(axis=0)
        assert 6.0 <= np.hypot(x, y) <= 10.0
        assert np.hypot(wire[:, 0] - x, wire[:, 1] - y).min() < 0.12  # the wire reaches each pole


@pytest.mark.parametrize("seed", SEEDS)
def test_terrain_is_gentle_and_flat_at_the_origin(plans, seed):
    plan = plans[seed]
    h, s = plan.heights, plan.spacing
    gy, gx = np.gradient(h, s)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    assert slope.max() < 15.0
    near = np.hypot(*np.meshgrid(plan.xs, plan.ys)) <= 4.0
    assert slope[near].max() < 6.0
    assert plan.height_at(0.0, 0.0) == 0.0
    assert plan.xs[0] == -30.0 and plan.xs[-1] == 30.0 and s == 0.5


@pytest.mark.parametrize("seed", SEEDS)
def test_pond_holds_water(plans, seed):
    plan = plans[seed]
    cx, cy = plan.pond_center
    assert plan.pond_water_z > plan.height_at(cx, cy) + 0.3  # deep enough to stand a pose in
    water = plan.element_vertices(plan.elements_of("water")[0])
    assert np.allclose(water[:, 2], plan.pond_water_z)
    rim = water[np.hypot(water[:, 0] - cx, water[:, 1] - cy) > 0.5 * plan.water_radius]
    assert (plan.height_at(rim[:, 0], rim[:, 1]) > plan.pond_water_z).all()  # its edge is under ground


def test_poses(plans):
    plan = plans[0]
    assert plan.poses["origin"] == (0.0, 0.0, 0.0)
    assert plan.poses["on_water"][:2] == plan.pond_center
    x, y, _ = plan.poses["on_rock"]
    assert (x, y) == tuple(plan.rock_positions[0, :2])
    assert plan.rock_radii[0] == plan.rock_radii.max()
    assert np.isnan(plan.height_at(*plan.poses["off_world"][:2]))
    rock = plan.element_vertices(plan.elements_of("rock")[0])
    assert rock[:, 2].max() > plan.height_at(x, y) + 0.4  # standing there means standing on the rock


def test_height_at_is_vectorised_exact_at_vertices_and_nan_outside(plans):
    plan = plans[0]
    assert isinstance(plan.height_at(1.0, 2.0), float)
    gx, gy = np.meshgrid(plan.xs, plan.ys)
    assert np.array_equal(plan.height_at(gx, gy), plan.heights)
    out = plan.height_at(np.array([30.01, -31.0, 0.0]), np.array([0.0, 0.0, 30.5]))
    assert np.isnan(out).all()
    # linear along a cell edge
    x0, x1 = plan.xs[60], plan.xs[61]
    mid = plan.height_at((x0 + x1) / 2, plan.ys[40])
    assert mid == pytest.approx((plan.heights[40, 60] + plan.heights[40, 61]) / 2, abs=1e-12)


# --- Blender -----------------------------------------------------------------


def test_height_at_matches_the_terrain_mesh_blender_casts(empty_scene, plans):
    plan = plans[1]
    terrain = plan.elements_of("terrain")[0]
    v, f = plan.element_vertices(terrain), plan.prototypes[terrain.proto].faces
    mesh_object("terrain", v, f, wildscan_collection(), "terrain", 1)
    rng = np.random.default_rng(5)
    xy = rng.uniform(-29.9, 29.9, (3000, 2))
    top = 10.0
    origins = np.column_stack([xy, np.full(len(xy), top)])
    directions = np.broadcast_to([0.0, 0.0, -1.0], origins.shape)
    hits = BlenderRayCastBackend().cast(origins, directions, 30.0)
    assert hits.hit.all()
    np.testing.assert_allclose(top - hits.distance, plan.height_at(xy[:, 0], xy[:, 1]), atol=1e-5)


def test_build_test_world_creates_tagged_generated_objects(empty_scene):
    plan = build_test_world(3)
    coll = bpy.data.collections["WildScan"]
    assert coll.get("wildscan_generated") and coll.name in bpy.context.scene.collection.children
    objs = list(coll.objects)
    assert len(objs) == len(plan.elements)
    by_name = {o.name: o for o in objs}
    for el in plan.elements:
        obj = by_name[el.name]
        assert obj["wildscan_class"] == el.wildscan_class
        assert obj["wildscan_instance"] == el.instance
        assert obj["wildscan_generated"]
        assert len(obj.data.polygons) == len(plan.prototypes[el.proto].faces)
        co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
        obj.data.vertices.foreach_get("co", co)
        np.testing.assert_allclose(co.reshape(-1, 3), plan.element_vertices(el), atol=1e-5)


def test_rebuild_replaces_only_generated_objects(empty_scene):
    user_mesh = bpy.data.meshes.new("user_mesh")
    user_in_scene = bpy.data.objects.new("user_cube", user_mesh)
    bpy.context.scene.collection.objects.link(user_in_scene)
    build_test_world(1)
    coll = bpy.data.collections["WildScan"]
    user_in_ours = bpy.data.objects.new("user_in_wildscan", user_mesh)
    coll.objects.link(user_in_ours)
    n_meshes = len(bpy.data.meshes)

    plan = build_test_world(2)
    assert len(bpy.data.meshes) == n_meshes  # old generated meshes were freed, not leaked
    names = {o.name for o in coll.objects}
    assert names == {e.name for e in plan.elements} | {"user_in_wildscan"}
    assert bpy.data.objects.get("user_cube") is user_in_scene

    removed = remove_generated("WildScan")
    assert removed == len(plan.elements)
    assert {o.name for o in bpy.data.objects} == {"user_cube", "user_in_wildscan"}
    assert bpy.data.meshes.get("user_mesh") is not None
    # the generated collection stays while the user's object lives in it
    assert list(bpy.data.collections["WildScan"].objects) == [user_in_ours]


def test_remove_generated_drops_an_emptied_generated_collection_but_not_a_user_one(empty_scene):
    build_test_world(0)
    remove_generated("WildScan")
    assert bpy.data.collections.get("WildScan") is None
    assert remove_generated("WildScan") == 0

    user_coll = bpy.data.collections.new("Mine")
    bpy.context.scene.collection.children.link(user_coll)
    build_test_world(0, collection_name="Mine")
    assert not user_coll.get("wildscan_generated")
    remove_generated("Mine")
    assert bpy.data.collections.get("Mine") is user_coll and len(user_coll.objects) == 0


def test_mesh_object_takes_quads(empty_scene):
    v, _ = primitives.box((0, 0, 0), (2, 2, 2))
    quads = np.array([(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)])
    obj = mesh_object("cube", v, quads, wildscan_collection(), "rock", 4)
    me = obj.data
    assert len(me.polygons) == 6 and len(me.edges) == 12 and len(me.loops) == 24
    totals = np.empty(6, dtype=np.int32)
    me.polygons.foreach_get("loop_total", totals)
    assert (totals == 4).all()
    assert not me.validate()  # nothing to fix
    with pytest.raises(ValueError):
        mesh_object("bad", v, quads + 8, wildscan_collection())
