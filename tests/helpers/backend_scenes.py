"""Scenes for the ray-backend tests (bpy wheel), shared by test_backends.py,
test_stability.py and test_scene_file.py: meshes built from plain bpy mesh data in a
factory-empty file, their ground truth in float64, and every backend over them."""

from __future__ import annotations

import math

import bpy
import numpy as np

from wildscan.core.classes import class_id_for_tag
from wildscan.core.hits import RayHits
from wildscan.core.rng import stage_seed
from wildscan.raycast import select
from wildscan.raycast.extract import extract_scene
from wildscan.raycast.geometry import SceneGeometry

BACKENDS = ("blender", "bvh", "embree", "open3d")


def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def add_mesh(
    name,
    vertices,
    faces,
    wildscan_class=None,
    instance=None,
    location=(0, 0, 0),
    rotation=(0, 0, 0),
    scale=(1, 1, 1),
    collection=None,
    mesh=None,
):
    if mesh is None:
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(np.asarray(vertices, dtype=float).tolist(), [], np.asarray(faces).tolist())
        mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location, obj.rotation_euler, obj.scale = location, rotation, scale
    if wildscan_class is not None:
        obj["wildscan_class"] = wildscan_class
    if instance is not None:
        obj["wildscan_instance"] = instance
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def world_geometry(objects) -> SceneGeometry:
    """Ground truth for plain (modifier-free, non-instanced) mesh objects with triangle
    faces: float32 vertices as stored, world matrix applied in float64."""
    bpy.context.view_layer.update()
    verts, faces, cls, inst, idx = [], [], [], [], []
    start = 0
    for k, obj in enumerate(objects):
        mesh = obj.data
        co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
        loops = np.empty(len(mesh.loops), dtype=np.int32)
        mesh.loops.foreach_get("vertex_index", loops)
        f = loops.reshape(-1, 3)
        m = np.array(obj.matrix_world, dtype=np.float64)
        verts.append(co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3])
        faces.append(f + start)
        start += len(mesh.vertices)
        cls.append(np.full(len(f), class_id_for_tag(obj.get("wildscan_class"))))
        inst.append(np.full(len(f), int(obj.get("wildscan_instance", 0))))
        idx.append(np.full(len(f), k))
    g = SceneGeometry(
        np.concatenate(verts),
        np.concatenate(faces),
        np.concatenate(cls),
        np.concatenate(inst),
        np.concatenate(idx),
        tuple(o.name for o in objects),
    )
    g.offset = np.round(g.vertices.mean(axis=0))
    return g


def make_all(names=BACKENDS, geometry=None) -> dict:
    """Every backend over the current scene, the fast ones sharing one extraction."""
    geometry = geometry if geometry is not None else extract_scene()
    return {name: select.make_backend(name, geometry=geometry, notify=None) for name in names}


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_dirs(n, stage, seed=0):
    """Random unit directions from numpy's own normals (the counts tests record were measured
    on these rays; WildScan's generator draws its normals another way)."""
    return unit(np.random.Generator(np.random.PCG64(stage_seed(seed, stage))).normal(size=(n, 3)))


def grid_mesh(nx, ny, size_x, size_y, heights=None):
    xs = np.linspace(-size_x / 2, size_x / 2, nx + 1)
    ys = np.linspace(-size_y / 2, size_y / 2, ny + 1)
    x, y = np.meshgrid(xs, ys)
    z = np.zeros_like(x) if heights is None else heights(x, y)
    verts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i = np.arange(nx * ny)
    a = (i // nx) * (nx + 1) + i % nx
    faces = np.concatenate([np.stack([a, a + 1, a + nx + 2], 1), np.stack([a, a + nx + 2, a + nx + 1], 1)])
    return verts, faces


def uv_sphere(radius, rings, segments):
    theta = np.linspace(0, math.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * math.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    verts = radius * np.concatenate([[[0, 0, 1]], ring, [[0, 0, -1]]])
    faces = []
    last = len(verts) - 1
    for s in range(segments):
        n = (s + 1) % segments
        faces.append((0, 1 + s, 1 + n))
        faces.append((last, 1 + (rings - 2) * segments + n, 1 + (rings - 2) * segments + s))
        for r in range(rings - 2):
            a, b = 1 + r * segments + s, 1 + r * segments + n
            c, d = a + segments, b + segments
            faces += [(a, c, d), (a, d, b)]
    return verts, np.array(faces)


def cylinder_mesh(radius, height, sides):
    phi = np.linspace(0, 2 * math.pi, sides, endpoint=False)
    ring = np.stack([radius * np.cos(phi), radius * np.sin(phi)], 1)
    verts = np.concatenate(
        [np.c_[ring, np.zeros(sides)], np.c_[ring, np.full(sides, height)], [[0, 0, 0], [0, 0, height]]]
    )
    faces = []
    for s in range(sides):
        n = (s + 1) % sides
        faces += [
            (s, n, sides + n),
            (s, sides + n, sides + s),
            (2 * sides, n, s),
            (2 * sides + 1, sides + s, sides + n),
        ]
    return verts, np.array(faces)


def box_mesh(sx, sy, sz):
    v = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float) * [
        sx / 2,
        sy / 2,
        sz / 2,
    ]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])


def labels_of(hits: RayHits):
    return list(zip(hits.class_id.tolist(), hits.instance.tolist()))


# -- analytic primitives ----------------------------------------------------------------------
