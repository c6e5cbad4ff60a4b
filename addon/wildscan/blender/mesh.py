"""numpy -> Blender mesh objects, and the bookkeeping that keeps WildScan's objects
apart from the user's (every object or collection created here carries
`wildscan_generated = True`; only those are ever removed).

Works on Blender 3.4 and 5.0: polygons are built with foreach_set on
`loop_start` (and on `loop_total` where it is still writable, i.e. before 4.0).
"""

from __future__ import annotations

import bpy
import numpy as np

from ..core.classes import CLASS_PROP, COLOR_BY_ID, INSTANCE_PROP, WATER_ID, class_id_for_tag
from . import WORLD_COLLECTION

GENERATED = "wildscan_generated"
# On the root collection of a world WildScan built: how a rebuild finds it whatever the
# user renamed it to. Worlds saved before it existed carry the seed there instead.
WORLD_ROOT_PROP = "wildscan_world"
WORLD_SEED_PROP = "wildscan_seed"

# Since 4.0 a polygon's size is derived from the next polygon's loop_start.
_LOOP_TOTAL_WRITABLE = not bpy.types.MeshPolygon.bl_rna.properties["loop_total"].is_readonly


def mesh_data(name: str, vertices, faces) -> bpy.types.Mesh:
    """Mesh datablock from (V,3) vertices and (F,3) or (F,4) vertex indices, without any
    per-vertex Python."""
    verts = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    if faces.ndim != 2 or faces.shape[1] not in (3, 4):
        raise ValueError(f"faces must be (F, 3) or (F, 4), got shape {faces.shape}")
    if faces.size and (faces.min() < 0 or faces.max() >= len(verts)):
        raise ValueError(f"face indices out of range 0..{len(verts) - 1}")
    n_faces, corners = faces.shape
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", verts.ravel())
    mesh.loops.add(faces.size)
    mesh.loops.foreach_set("vertex_index", faces.ravel())
    mesh.polygons.add(n_faces)
    mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, corners, dtype=np.int32))
    if _LOOP_TOTAL_WRITABLE:
        mesh.polygons.foreach_set("loop_total", np.full(n_faces, corners, dtype=np.int32))
    mesh.update(calc_edges=True)
    mesh[GENERATED] = True
    return mesh


def tag_object(obj: bpy.types.Object, wildscan_class: str | None, instance: int | None) -> None:
    """Write the class/instance tags a scan reads; also colour the object by its class
    so the viewport (Object colour mode) shows the labels."""
    if wildscan_class is not None:
        obj[CLASS_PROP] = str(wildscan_class)
        class_id = class_id_for_tag(wildscan_class)
        # water has no colour tag (it never reaches a point cloud); show it as water
        r, g, b = (0.2, 0.45, 0.8) if class_id == WATER_ID else (COLOR_BY_ID[class_id] / 255.0).tolist()
        obj.color = (r, g, b, 1.0)
    if instance is not None:
        obj[INSTANCE_PROP] = int(instance)


def mesh_object(
    name: str,
    vertices,
    faces,
    collection: bpy.types.Collection,
    wildscan_class: str | None = None,
    instance: int | None = None,
) -> bpy.types.Object:
    """A new generated mesh object linked into `collection`."""
    obj = bpy.data.objects.new(name, mesh_data(name, vertices, faces))
    obj[GENERATED] = True
    tag_object(obj, wildscan_class, instance)
    collection.objects.link(obj)
    return obj


def wildscan_collection(
    name: str = WORLD_COLLECTION, parent: bpy.types.Collection | None = None
) -> bpy.types.Collection:
    """Get or create the collection WildScan builds into, linked under `parent` (default:
    the scene's master collection). An existing user collection of that name is reused
    but not marked, so removing generated objects never deletes it."""
    coll = bpy.data.collections.get(name)
    if coll is None:
        coll = bpy.data.collections.new(name)
        coll[GENERATED] = True
    if parent is None:
        parent = bpy.context.scene.collection
        if coll in parent.children_recursive:
            return coll  # already in the scene, wherever the user moved it
    if coll.name not in parent.children:
        parent.children.link(coll)
    return coll


def _tree(coll: bpy.types.Collection) -> list[bpy.types.Collection]:
    out = [coll]
    for child in coll.children:
        out += _tree(child)
    return out


def remove_objects_and_their_meshes(objects) -> None:
    """Delete these objects, then the meshes WildScan made for them that nothing uses now
    (a user's mesh is never deleted, even when one of our objects borrowed it)."""
    objects = list(objects)
    meshes = {o.data for o in objects if isinstance(o.data, bpy.types.Mesh) and o.data.get(GENERATED)}
    if objects:
        bpy.data.batch_remove(objects)
    orphans = [m for m in meshes if m.users == 0]
    if orphans:
        bpy.data.batch_remove(orphans)


def remove_generated(collection_name: str = WORLD_COLLECTION) -> int:
    """Delete the generated objects in that collection (and its children), the generated
    meshes they leave unused, and the generated collections left empty. User objects,
    meshes and collections are left as they are. Returns the number of objects removed."""
    root = bpy.data.collections.get(collection_name)
    if root is None:
        return 0
    collections = _tree(root)
    objects = {o for c in collections for o in c.objects if o.get(GENERATED)}
    remove_objects_and_their_meshes(objects)
    # children first, so a parent becomes empty once its generated children are gone
    for coll in reversed(collections):
        if coll.get(GENERATED) and not coll.objects and not coll.children:
            bpy.data.collections.remove(coll)
    return len(objects)


def is_world_root(coll) -> bool:
    return bool(coll.get(GENERATED)) and (coll.get(WORLD_ROOT_PROP) or coll.get(WORLD_SEED_PROP) is not None)


def world_root(scene=None):
    """The root collection of the world WildScan built in `scene` (default: the current
    one), found by its marker, not its name (a user may rename it); None without one."""
    scene = scene if scene is not None else bpy.context.scene
    roots = [c for c in scene.collection.children_recursive if is_world_root(c)]
    # the one still called by the default name first, then by name: the same answer every time
    roots.sort(key=lambda c: (c.name != WORLD_COLLECTION, c.name))
    return roots[0] if roots else None


def world_element_objects(scene=None) -> set:
    """Every object of the scene WildScan built as part of a world: marked generated and
    tagged with a class (the pose marker and scan clouds are generated but untagged),
    wherever the user moved it."""
    scene = scene if scene is not None else bpy.context.scene
    return {o for o in scene.objects if o.get(GENERATED) and o.get(CLASS_PROP) is not None}
