"""Read the evaluated Blender scene once into a numpy `SceneGeometry` (bpy).

What is read: every mesh-like object the laser sees (`scanned`; docs/scanning.md "Which objects
a scan sees"): what the viewport shows, as `scene.ray_cast` sees it, with modifiers
evaluated and instances (collection instances, instancing by vertices/faces,
geometry-node instances) expanded, via
`depsgraph.object_instances`. Each object's evaluated mesh comes from
`to_mesh()` + `loop_triangles` with `foreach_get`, is released with
`to_mesh_clear()`, and its world matrix is applied in float64 numpy.

Nothing in the scene changes: no modifier is applied, no object or mesh is
created, selected or moved (to_mesh's temporary mesh belongs to the evaluated
object and is freed at once).

Labels: class and instance come from the ORIGINAL object's custom properties
`wildscan_class` / `wildscan_instance` (evaluated copies need not carry them).
For an instance each property is taken from the instanced object when it has
it, else from the instancer: a template rock tagged `"rock"` but without an
instance id, instanced by empties that each carry their own
`wildscan_instance`, gives every copy its own instance id.

Which objects: an object is scanned when it is visible in the view layer
(`visible_get()`: not hidden with its eye icon or its collection's, not disabled in
viewports, not in an excluded collection) and its world matrix is not singular (an
axis scaled to exactly zero: scene.ray_cast cannot see it). A copy made by instancing
is scanned when its instancer is. `hide_render` does not matter: the viewport shows it.
The add-on's scan clouds are loose points without faces, so they never are.

Tags are read from every visible object, near or far, and a wrong one is a UserError
(core/classes.py object_tags), so every backend refuses the same scenes.

Cropping (when `center` and `radius` are given): see geometry.py: triangles
whose XY bounding box lies within `radius` of the centre (a vertical cylinder),
objects whose whole bounding box lies outside are skipped before their mesh is
even built.

Works on Blender 3.4 and 5.0 (only APIs present in both are used).
"""

from __future__ import annotations

import numpy as np

from .base import reflectance_from, tags_from
from .geometry import SceneGeometry, concatenate, local_origin, triangles_near_xy, world_vertices

# Object types whose evaluated geometry to_mesh() can turn into triangles.
MESH_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "FONT", "META"})


def extract_scene(depsgraph=None, center=None, radius=None) -> SceneGeometry:
    """World-space triangles of the evaluated scene with per-triangle class, instance and
    object. `center` ((2,) or (3,) world metres) and `radius` (metres) crop to what a scan
    from there can reach; either None keeps everything."""
    import bpy

    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    crop = None
    if center is not None and radius is not None:
        center = np.asarray(center, dtype=np.float64).ravel()
        crop = (center[:2], float(radius))

    names: dict[str, int] = {}
    parts: list[SceneGeometry] = []
    mesh_cache: dict = {}
    view_layer = depsgraph.view_layer
    for inst in depsgraph.object_instances:
        part = _instance_part(inst, view_layer, crop, names, mesh_cache)
        if part is not None:
            parts.append(part)

    geometry = concatenate(parts, object_names=tuple(names))
    geometry.offset = local_origin(geometry.vertices, geometry.faces, center if crop else None)
    geometry.cover = _scene_cover(depsgraph.scene)
    return geometry


def _scene_cover(scene):
    """The world's sward (core/world/cover.py), kept on its root collection: the scene's one
    collection carrying the cover's properties (None: bare ground)."""
    from ..core.world.cover import SHAPE_PROP, CoverGrid

    roots = sorted(
        (c for c in scene.collection.children_recursive if c.get(SHAPE_PROP) is not None),
        key=lambda c: c.name,
    )
    return CoverGrid.from_props(roots[0]) if roots else None


def _instance_part(inst, view_layer, crop, names: dict[str, int], mesh_cache: dict) -> SceneGeometry | None:
    """The triangles one depsgraph instance contributes (None when it has none in reach)."""
    obj = inst.object
    if obj is None or obj.type not in MESH_TYPES or not scanned(inst, view_layer):
        return None
    # Copy now: an instance's matrix and object are only valid during this iteration step.
    matrix = np.array(inst.matrix_world, dtype=np.float64)
    if singular(matrix):
        return None
    class_id, instance, reflectivity, name = _tags(inst)
    reflectance = _reflectance(inst)
    if crop is not None and not _box_within(obj, matrix, *crop):
        return None
    local = _local_mesh(obj, inst.is_instance, mesh_cache)
    if local is None:
        return None
    vertices = world_vertices(local[0], matrix)
    faces = local[1]
    keep = None
    if crop is not None:
        keep = triangles_near_xy(vertices, faces, *crop)
        if not keep.any():
            return None
    index = names.setdefault(name, len(names))
    part = SceneGeometry(
        vertices, faces, class_id, instance, index, reflectivity=reflectivity, reflectance=reflectance
    )
    # drop the cropped triangles' vertices too: they would widen the float32 extent
    return part if keep is None or keep.all() else part.subset(keep)


def scanned(inst, view_layer) -> bool:
    """Whether the laser sees this depsgraph instance: the object (for a copy made by
    instancing, its instancer) is visible in the depsgraph's view layer (which need not be
    the context's: a scene outside any window has its own)."""
    source = inst.parent if inst.is_instance and inst.parent is not None else inst.object
    original = source.original if source.original is not None else source
    return bool(original.visible_get(view_layer=view_layer))


def singular(matrix) -> bool:
    """An axis scaled to exactly zero: Blender's ray_cast cannot invert the matrix and so
    never hits the object; no backend scans it."""
    m = np.asarray(matrix, dtype=np.float64)[:3, :3]
    return float(np.linalg.det(m)) == 0.0


def check_scene_tags(depsgraph) -> None:
    """Raise UserError for the first visible object whose tags are wrong (every backend
    checks the whole scene up front, so none refuses a scene another accepts)."""
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj is not None and obj.type in MESH_TYPES and scanned(inst, depsgraph.view_layer):
            _tags(inst)
            _reflectance(inst)


def _box_within(obj, matrix: np.ndarray, center_xy: np.ndarray, radius: float) -> bool:
    """Whether the object's evaluated bounding box comes within `radius` of the centre in XY."""
    corners = np.array([tuple(c) for c in obj.bound_box], dtype=np.float64)
    xy = (corners @ matrix[:3, :3].T + matrix[:3, 3])[:, :2]
    gap = np.clip(center_xy, xy.min(axis=0), xy.max(axis=0)) - center_xy
    return float(gap @ gap) <= radius * radius


def _local_mesh(obj, is_instance: bool, mesh_cache: dict):
    """(vertices (V,3) float64 object space, faces (T,3) int32) of the evaluated object.

    Copies of one instanced object share their evaluated mesh, so it is read once
    (keyed by original object and evaluated data, which tell geometry-node
    instances of different meshes apart)."""
    key = None
    if is_instance:
        data = obj.data
        key = (obj.original.as_pointer(), data.as_pointer() if data is not None else 0)
        if key in mesh_cache:
            return mesh_cache[key]
    arrays = _read_evaluated_mesh(obj)
    if key is not None:
        mesh_cache[key] = arrays
    return arrays


def _read_evaluated_mesh(obj):
    mesh = obj.to_mesh()
    if mesh is None:
        return None
    try:
        mesh.calc_loop_triangles()
        n_tris = len(mesh.loop_triangles)
        if n_tris == 0:
            return None
        co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
        tris = np.empty(n_tris * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
    finally:
        obj.to_mesh_clear()
    return co.reshape(-1, 3).astype(np.float64), tris.reshape(-1, 3)


def _reflectance(inst) -> float:
    """The instance's `wildscan_reflectance` (nan: none), from original objects as _tags."""
    sources = [inst.object.original]
    if inst.is_instance and inst.parent is not None:
        sources.append(inst.parent.original)
    return reflectance_from(sources)


def _tags(inst) -> tuple[int, int, float, str]:
    """(class id, instance id, reflectivity (nan: the class's), object name) of a
    depsgraph instance, from original objects."""
    own = inst.object.original
    sources = [own]
    if inst.is_instance and inst.parent is not None:
        sources.append(inst.parent.original)
    class_id, instance, reflectivity = tags_from(sources)
    return class_id, instance, reflectivity, own.name
