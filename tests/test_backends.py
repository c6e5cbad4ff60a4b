"""Ray backends (blender, bvh, embree) behind one interface, and scene extraction.

Scenes are built from plain bpy mesh data (bpy.data.meshes.new + from_pydata) in a
factory-empty file. Ground truth is computed here, independently of extraction: the
mesh's float32 vertices as Blender stores them, times the object's world matrix, in
float64 (`world_geometry`), then every triangle tested by brute force
(reference.reference_hits / check_hits). For sphere and cylinder that ground truth
is the faceted MESH; the hit points are also checked against the analytic shape,
between the inscribed and circumscribed surfaces of the facets.
"""

from __future__ import annotations

import math
import subprocess
import sys

import bpy
import numpy as np
import pytest

from wildscan.core.classes import class_id_for_tag
from wildscan.core.errors import UserError
from wildscan.raycast import select
from wildscan.raycast.bvh_backend import BVHBackend
from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.extract import extract_scene
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.padding import pad_triangles
from wildscan.raycast.reference import check_hits, reference_hits

from tests.helpers.backend_scenes import (
    BACKENDS,
    add_mesh,
    box_mesh,
    cylinder_mesh,
    empty_scene,
    grid_mesh,
    labels_of,
    make_all,
    random_dirs,
    unit,
    uv_sphere,
    world_geometry,
)

RANGE_TOL = 1e-4


SPHERE = dict(radius=1.5, rings=24, segments=48, center=(4.0, 1.0, 0.5))
CYLINDER = dict(radius=0.6, height=3.0, sides=48, base=(-3.0, 2.0, -0.5))


def build_primitives():
    empty_scene()
    plane = add_mesh(
        "plane",
        [(-20, -20, 0), (20, -20, 0), (20, 20, 0), (-20, 20, 0)],
        [(0, 1, 2), (0, 2, 3)],
        "terrain",
        1,
        location=(1, 2, -1.3),
        rotation=(0.35, 0.0, 0.17),
    )
    box = add_mesh(
        "box", *box_mesh(2.0, 1.0, 1.5), "rock", 2, location=(0.5, -3.0, 0.2), rotation=(0.1, 0.2, 0.7)
    )
    sphere = add_mesh(
        "sphere",
        *uv_sphere(SPHERE["radius"], SPHERE["rings"], SPHERE["segments"]),
        "bush",
        3,
        location=SPHERE["center"],
    )
    cyl = add_mesh(
        "cylinder",
        *cylinder_mesh(CYLINDER["radius"], CYLINDER["height"], CYLINDER["sides"]),
        "trunk",
        4,
        location=CYLINDER["base"],
    )
    return [plane, box, sphere, cyl]


PRIMITIVE_ORIGINS = ((0.0, 0.0, 1.0), (2.5, -1.0, 2.0), (-1.5, 3.5, 0.8))


@pytest.fixture(scope="module")
def primitives():
    objects = build_primitives()
    truth = world_geometry(objects)
    backends = make_all()
    casts = {}
    for name, backend in backends.items():
        casts[name] = [
            backend.cast(np.array(o), random_dirs(2000, f"prim {k}"), 25.0)
            for k, o in enumerate(PRIMITIVE_ORIGINS)
        ]
    return truth, casts


@pytest.mark.slow
@pytest.mark.parametrize("backend", BACKENDS)
def test_every_backend_matches_the_exact_facets(primitives, backend):
    truth, casts = primitives
    worst = 0.0
    for k, origin in enumerate(PRIMITIVE_ORIGINS):
        dirs = random_dirs(2000, f"prim {k}")
        hits = casts[backend][k]
        ok = check_hits(truth, np.array(origin), dirs, 25.0, hits)
        assert ok.all(), f"{backend}: {np.count_nonzero(~ok)} wrong rays from {origin}"
        ref = reference_hits(truth, np.array(origin), dirs, 25.0)
        sure = np.isfinite(ref["distance"]) & ~ref["ambiguous_before"]
        assert np.array_equal(hits.hit[sure], np.ones(sure.sum(), bool))
        worst = max(worst, float(np.abs(hits.distance[sure] - ref["distance"][sure]).max()))
        assert hits.hit.sum() > 700  # the primitives surround the origins: many rays hit
    assert worst <= RANGE_TOL, f"{backend}: range error {worst:.2e} m"


@pytest.mark.parametrize("backend", BACKENDS)
def test_hits_lie_on_the_analytic_plane_box_sphere_and_cylinder(primitives, backend):
    truth, casts = primitives
    found = set()
    for k, origin in enumerate(PRIMITIVE_ORIGINS):
        dirs = random_dirs(2000, f"prim {k}")
        hits = casts[backend][k]
        points = np.array(origin) + dirs * np.where(hits.hit, hits.distance, 0)[:, None]
        for inst, check in ((1, _on_plane), (2, _on_box), (3, _on_sphere), (4, _on_cylinder)):
            mine = hits.instance == inst
            found.add(inst) if mine.any() else None
            err = check(points[mine])
            assert err.max(initial=0) <= RANGE_TOL, f"{backend}: instance {inst} off by {err.max():.2e} m"
    assert found == {1, 2, 3, 4}


def _to_local(name, points):
    m = np.array(bpy.data.objects[name].matrix_world, dtype=np.float64)
    return (points - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T


def _on_plane(points):
    return np.abs(_to_local("plane", points)[:, 2])


def _on_box(points):
    p = np.abs(_to_local("box", points)) - [1.0, 0.5, 0.75]
    # on the surface: the largest outward coordinate is zero, none exceeds it
    return np.abs(p.max(axis=1))


def _on_sphere(points):
    r, rings, segs = SPHERE["radius"], SPHERE["rings"], SPHERE["segments"]
    d = np.linalg.norm(_to_local("sphere", points), axis=1)
    inner = r * math.cos(math.pi / rings) * math.cos(math.pi / segs)  # facets lie between these
    return np.maximum(np.maximum(inner - d, d - r), 0.0)


def _on_cylinder(points):
    p = _to_local("cylinder", points)
    r, h, sides = CYLINDER["radius"], CYLINDER["height"], CYLINDER["sides"]
    rho = np.hypot(p[:, 0], p[:, 1])
    side = np.maximum(np.maximum(r * math.cos(math.pi / sides) - rho, rho - r), 0.0) + np.maximum(
        np.maximum(-p[:, 2], p[:, 2] - h), 0.0
    )
    cap = np.minimum(np.abs(p[:, 2]), np.abs(p[:, 2] - h)) + np.maximum(rho - r, 0.0)
    return np.minimum(side, cap)


# -- label agreement on the test world -------------------------------------------------------


@pytest.mark.slow
def test_backends_agree_on_the_test_world():
    from wildscan.blender.testworld import build_test_world
    from wildscan.core.placement import Pose, place
    from wildscan.core.sensors import beam_directions

    empty_scene()
    build_test_world(7)
    backends = make_all()
    placement = place(backends["embree"], Pose(0.0, 0.0, 20.0))
    dirs = beam_directions(2.0)[0] @ placement.rotation.T
    hits = {n: b.cast(placement.optical_centre, dirs, 15.0) for n, b in backends.items()}
    ref = hits["blender"]
    classes = set(ref.class_id[ref.hit].tolist())
    assert len(classes) >= 8  # a varied scan, not just terrain
    for name in ("bvh", "embree", "open3d"):
        h = hits[name]
        same = (h.class_id == ref.class_id) & (h.instance == ref.instance)
        assert same.mean() >= 0.9999, f"{name}: {np.count_nonzero(~same)} of {len(same)} labels differ"
        both = same & h.hit
        close = np.abs(h.distance[both] - ref.distance[both]) <= RANGE_TOL
        assert close.mean() >= 0.9999, f"{name}: {np.count_nonzero(~close)} ranges differ by > 1e-4 m"
        assert h.untagged_objects == ref.untagged_objects


# -- extraction: transforms, tags, modifiers, instances, nothing changed -------------------------


def _snapshot():
    """Everything extraction could conceivably disturb."""
    objects = []
    for o in bpy.data.objects:
        objects.append(
            (
                o.name,
                o.type,
                tuple(round(v, 9) for row in o.matrix_world for v in row),
                tuple(sorted((k, str(o[k])) for k in o.keys())),
                tuple((m.name, m.type) for m in o.modifiers),
                o.data.name if o.data else None,
                o.select_get(),
                o.hide_get(),
                o.hide_viewport,
                tuple(o.location),
            )
        )
    meshes = []
    for m in bpy.data.meshes:
        co = np.empty(len(m.vertices) * 3, dtype=np.float32)
        m.vertices.foreach_get("co", co)
        meshes.append((m.name, len(m.vertices), len(m.polygons), co.tobytes(), m.users))
    collections = tuple((c.name, tuple(o.name for o in c.objects)) for c in bpy.data.collections)
    return sorted(objects), sorted(meshes), collections, len(bpy.data.objects), len(bpy.data.meshes)


def build_instancing_scene():
    empty_scene()
    template = bpy.data.collections.new("rock template")  # not linked to the scene: only instanced
    add_mesh("template rock", *box_mesh(1, 1, 1), "rock", None, collection=template)
    for i, x in enumerate((5.0, 10.0)):
        empty = bpy.data.objects.new(f"rock instancer {i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = template
        empty.location = (x, 0.0, 0.5)
        empty["wildscan_instance"] = 21 + i
        bpy.context.scene.collection.objects.link(empty)
    arr = add_mesh("fence", *box_mesh(1, 0.2, 1), "fence", 30, location=(0.0, 5.0, 0.5))
    mod = arr.modifiers.new("copies", "ARRAY")
    mod.count = 3
    mod.relative_offset_displace = (1.5, 0.0, 0.0)
    shared = add_mesh("pole A", *box_mesh(0.2, 0.2, 3), "pole", 41, location=(0.0, -5.0, 1.5))
    add_mesh("pole B", None, None, "pole", 42, location=(3.0, -5.0, 1.5), mesh=shared.data)
    add_mesh("user cube", *box_mesh(1, 1, 1), location=(-6.0, 0.0, 0.5))
    bpy.context.view_layer.update()


# (x, y) above each copy, with the label it must get
INSTANCE_TARGETS = (
    ((5.0, 0.0), ("rock", 21)),
    ((10.0, 0.0), ("rock", 22)),
    ((0.0, 5.0), ("fence", 30)),
    ((1.5, 5.0), ("fence", 30)),
    ((3.0, 5.0), ("fence", 30)),
    ((0.0, -5.0), ("pole", 41)),
    ((3.0, -5.0), ("pole", 42)),
    ((-6.0, 0.0), ("unlabeled", 0)),
)


# scene.ray_cast reports the instanced object but not its instancer; the blender backend
# finds the instancer by matching the hit's matrix against depsgraph.object_instances, so
# it gives the copies their instancer's `wildscan_instance` as extraction does. Set this
# back to True only if a Blender version breaks that matching.
BLENDER_MISSES_INSTANCER_TAGS = False


def test_extraction_expands_instances_and_modifiers_without_changing_the_scene():
    build_instancing_scene()
    before = _snapshot()
    geometry = extract_scene()
    backends = make_all(geometry=geometry)
    origins = np.array([(x, y, 10.0) for (x, y), _ in INSTANCE_TARGETS])
    down = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    expected = [(class_id_for_tag(c) if c != "unlabeled" else 0, i) for _, (c, i) in INSTANCE_TARGETS]
    for name, backend in backends.items():
        hits = backend.cast(origins, down, 20.0)
        want = list(expected)
        if name == "blender" and BLENDER_MISSES_INSTANCER_TAGS:
            want[0] = want[1] = (class_id_for_tag("rock"), 0)
        assert labels_of(hits) == want, name
        assert hits.untagged_objects == {"user cube"}, name
    after = _snapshot()
    assert after == before

    # 2 rock copies + 3 fence copies + 2 poles + the user's cube, 12 triangles each
    assert geometry.triangle_count == 8 * 12
    pairs = set(zip(geometry.class_id.tolist(), geometry.instance.tolist()))
    assert pairs == set(expected)
    assert {"template rock", "fence", "pole A", "pole B", "user cube"} == set(geometry.object_names)


def test_extraction_applies_world_matrices_in_float64():
    empty_scene()
    obj = add_mesh(
        "tilted",
        *box_mesh(2, 1, 0.5),
        "rock",
        5,
        location=(10003.25, -7000.5, 12.0),
        rotation=(0.3, -0.2, 1.1),
        scale=(1.5, 0.5, 2.0),
    )
    truth = world_geometry([obj])
    geometry = extract_scene()
    assert np.allclose(geometry.triangles(), truth.triangles(), rtol=0, atol=1e-9)
    assert set(geometry.class_id.tolist()) == {class_id_for_tag("rock")}
    assert set(geometry.instance.tolist()) == {5}


def test_crop_keeps_what_a_scan_can_reach():
    empty_scene()
    add_mesh("ground", *grid_mesh(50, 50, 100.0, 100.0), "terrain", 1)
    for i, d in enumerate((10.0, 30.0, 60.0)):
        add_mesh(f"rock {d:g}", *box_mesh(1, 1, 1), "rock", 10 + i, location=(d * 0.6, d * 0.8, 0.5))
    whole = extract_scene()
    crop = extract_scene(center=(0.0, 0.0, 1.5), radius=35.0)
    assert set(crop.instance.tolist()) == {1, 10, 11}
    assert crop.triangle_count < whole.triangle_count
    lo = crop.vertices[crop.faces][:, :, :2].min(axis=1)
    hi = crop.vertices[crop.faces][:, :, :2].max(axis=1)
    gap = np.linalg.norm(np.clip(0.0, lo, hi), axis=1)
    assert gap.max() <= 35.0
    assert np.allclose(crop.offset, (0.0, 0.0, 2.0))
    # the same crop made from the whole extraction, and the same hits within reach
    again = whole.cropped((0.0, 0.0, 1.5), 35.0)
    assert again.triangle_count == crop.triangle_count
    dirs = random_dirs(5000, "crop")
    a = EmbreeBackend(whole).cast(np.array([0.0, 0.0, 1.5]), dirs, 30.0)
    b = EmbreeBackend(crop).cast(np.array([0.0, 0.0, 1.5]), dirs, 30.0)
    assert labels_of(a) == labels_of(b)
    assert np.array_equal(a.hit, b.hit) and np.allclose(a.distance[a.hit], b.distance[b.hit], atol=1e-9)


def test_hidden_objects_are_not_extracted():
    empty_scene()
    add_mesh("seen", *box_mesh(1, 1, 1), "rock", 1)
    hidden = add_mesh("hidden", *box_mesh(1, 1, 1), "rock", 2, location=(3, 0, 0))
    hidden.hide_set(True)
    geometry = extract_scene()
    assert set(geometry.instance.tolist()) == {1}


# -- backend selection -------------------------------------------------------------------------


def test_all_backends_are_available_here_and_auto_is_embree():
    empty_scene()
    add_mesh("ground", *grid_mesh(2, 2, 10, 10), "terrain", 1)
    assert select.available_backends() == ["embree", "open3d", "bvh", "blender"]
    lines = []
    assert select.make_backend("auto", notify=lines.append).name == "embree"
    for name in BACKENDS:
        assert select.make_backend(name, notify=lines.append).name == name
    assert lines == []


def test_missing_embreex_falls_back_to_open3d_then_bvh_and_says_so_once(monkeypatch):
    empty_scene()
    add_mesh("ground", *grid_mesh(2, 2, 10, 10), "terrain", 1)
    monkeypatch.setitem(sys.modules, "embreex", None)  # import embreex now raises ImportError
    for asked in ("auto", "embree"):
        lines = []
        backend = select.make_backend(asked, notify=lines.append)
        assert backend.name == "open3d"
        assert len(lines) == 1 and "'embree'" in lines[0] and "'open3d'" in lines[0] and "embreex" in lines[0]
    assert select.available_backends() == ["open3d", "bvh", "blender"]
    monkeypatch.setitem(sys.modules, "open3d", None)
    for asked, wanted in (("auto", "embree"), ("open3d", "open3d")):
        lines = []
        assert select.make_backend(asked, notify=lines.append).name == "bvh"
        assert len(lines) == 1 and f"'{wanted}'" in lines[0] and "'bvh'" in lines[0]
        assert "pip install" in lines[0]
    assert select.available_backends() == ["bvh", "blender"]
    lines = []
    assert select.make_backend("bvh", notify=lines.append).name == "bvh" and lines == []


def test_fallback_reaches_blender_and_then_fails_clearly(monkeypatch):
    empty_scene()
    real = select.missing_reason
    fast = ("embree", "open3d", "bvh")
    monkeypatch.setattr(select, "missing_reason", lambda n: "not here" if n in fast else real(n))
    lines = []
    assert select.make_backend("auto", notify=lines.append).name == "blender"
    assert len(lines) == 1 and "'blender'" in lines[0]
    monkeypatch.setattr(select, "missing_reason", lambda n: "not here")
    with pytest.raises(UserError, match="no ray backend"):
        select.make_backend("auto", notify=None)
    with pytest.raises(UserError, match="backend must be one of auto, embree, open3d, bvh, blender"):
        select.make_backend("optix")


def test_select_imports_without_bpy_or_embreex():
    code = (
        "import sys, wildscan.raycast.select as s, wildscan.raycast.geometry; "
        "assert not {'bpy', 'mathutils', 'embreex', 'open3d'} & set(sys.modules), sorted(sys.modules)"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)


# -- numpy-level pieces ------------------------------------------------------------------------


def test_padding_moves_every_edge_out_by_pad_and_keeps_the_plane():
    tris = np.array([[[0, 0, 0], [2, 0, 0], [0, 1, 0]], [[1, 1, 1], [3, 1, 2], [1, 4, 0]]], float)
    pad = 1e-3
    grown = pad_triangles(tris, pad)
    for t, g in zip(tris, grown):
        n = unit(np.cross(t[1] - t[0], t[2] - t[0]))
        assert np.allclose((g - t[0]) @ n, 0, atol=1e-12)  # same plane
        for k in range(3):  # each grown edge is parallel to the old one, pad further out
            a, b = g[k], g[(k + 1) % 3]
            m = unit(np.cross(n, b - a))  # inward normal of the grown edge
            assert np.isclose((t[k] - a) @ m, pad, atol=1e-12)
            assert np.isclose((t[(k + 1) % 3] - a) @ m, pad, atol=1e-12)


def test_float32_backends_stay_precise_10_km_from_the_origin():
    shift = np.array([10_000.0, -10_000.0, 30.0])
    tri = np.array([[[-5, -5, 0], [5, -5, 0.5], [0, 5, 1.0]]], float) + shift
    geometry = from_triangles(tri, class_id=1, instance=1)
    origin = shift + [0.123456, -0.654321, 7.0]
    dirs = unit(np.array([[0.01, 0.02, -1], [0.2, -0.1, -1], [-0.3, 0.05, -1]]))
    exact = reference_hits(geometry, origin, dirs, 30.0)["distance"]
    for backend in (EmbreeBackend(geometry), BVHBackend(geometry)):
        hits = backend.cast(origin, dirs, 30.0)
        assert np.abs(hits.distance - exact).max() <= 1e-9, backend.name


def test_max_range_is_exact_and_empty_scenes_miss():
    geometry = from_triangles([[[-1, -1, 0], [1, -1, 0], [0, 1, 0]]], class_id=1, instance=1)
    down = np.array([[0.0, 0.0, -1.0]])
    for backend in (EmbreeBackend(geometry), BVHBackend(geometry)):
        assert backend.cast(np.array([0, 0, 5.0]), down, 5.0).hit[0]
        assert not backend.cast(np.array([0, 0, 5.0]), down, 4.9999).hit[0]
        assert backend.cast(np.zeros(3), np.zeros((0, 3)), 5.0).distance.shape == (0,)
    empty = from_triangles(np.zeros((0, 3, 3)))
    for backend in (EmbreeBackend(empty), BVHBackend(empty)):
        assert not backend.cast(np.array([0, 0, 5.0]), down, 10.0).hit.any()


def test_first_hit_classes_are_the_cast_classes_up_to_the_exact_max_range():
    rng = np.random.default_rng(5)
    centres = rng.uniform(-3, 3, (400, 1, 3))
    soup = centres + rng.normal(0, 0.4, (400, 3, 3))
    geometry = from_triangles(soup, class_id=rng.integers(1, 13, 400), instance=1)
    origins = rng.uniform(-4, 4, (5000, 3))
    dirs = random_dirs(5000, "first-hit classes")
    for backend in (EmbreeBackend(geometry), BVHBackend(geometry)):
        for max_range in (0.5, 2.0, 9.0):
            classes = backend.first_hit_classes(origins, dirs, max_range)
            assert np.array_equal(classes, backend.cast(origins, dirs, max_range).class_id)
        hits = backend.cast(origins, dirs, 9.0)
        first = np.flatnonzero(hits.hit)[:50]  # each of these cut at exactly its hit distance
        for i in first:
            d = float(hits.distance[i])
            assert backend.first_hit_classes(origins[i], dirs[i : i + 1], d)[0] == hits.class_id[i]
            assert backend.first_hit_classes(origins[i], dirs[i : i + 1], np.nextafter(d, 0))[0] == -1
