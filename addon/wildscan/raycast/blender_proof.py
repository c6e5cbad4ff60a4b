"""The proof scene (raycast/proof.py) for Blender's own scene.ray_cast (bpy; thin).

scene.ray_cast casts into a Blender scene, so the known triangles become three tagged mesh
objects in a scene of their own, made for the proof and removed with their meshes right
after: the user's scenes and objects are never touched, and nothing is left behind.
"""

from __future__ import annotations

from contextlib import contextmanager

import bpy

from ..core.classes import BY_ID, CLASS_PROP, INSTANCE_PROP
from .blender_backend import BlenderRayCastBackend


@contextmanager
def proof_scene_backend(scene):
    """A BlenderRayCastBackend over `scene` (proof.KnownScene) built as a scene of its own."""
    made_scene = bpy.data.scenes.new("wildscan proof")
    objects, meshes = [], []
    try:
        for k, name in enumerate(scene.objects):
            rows = scene.object_index == k
            tris = scene.triangles[rows]
            mesh = bpy.data.meshes.new(name)
            meshes.append(mesh)
            vertices = [tuple(v) for v in tris.reshape(-1, 3).tolist()]
            faces = [(3 * t, 3 * t + 1, 3 * t + 2) for t in range(len(tris))]
            mesh.from_pydata(vertices, [], faces)
            mesh.update()
            obj = bpy.data.objects.new(name, mesh)
            objects.append(obj)
            obj[CLASS_PROP] = BY_ID[int(scene.class_id[rows][0])].name
            obj[INSTANCE_PROP] = int(scene.instance[rows][0])
            made_scene.collection.objects.link(obj)
        yield BlenderRayCastBackend(scene=made_scene)
    finally:
        for obj in objects:
            bpy.data.objects.remove(obj)
        for mesh in meshes:
            bpy.data.meshes.remove(mesh)
        bpy.data.scenes.remove(made_scene)
