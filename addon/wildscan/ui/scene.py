"""What the add-on keeps in the scene (bpy): the pose marker and the scan clouds.

Both live in their own collection, "WildScan Scans", outside the world's
"WildScan" collection, so generating a new world keeps the pose and the scans,
and scanning never adds anything to the world that the next scan would see.

A cloud is one mesh object of loose vertices, at the points' world positions
(so it lies on the world that was scanned), carrying everything its PLY file
needs as point attributes plus the scan metadata as JSON. It is self-contained:
it survives save, reload and undo, and exporting it later writes the same
records `wildscan scan` writes.
"""

from __future__ import annotations

import json
import math

import bpy
import numpy as np

from ..blender.mesh import GENERATED, remove_objects_and_their_meshes, wildscan_collection
from ..core.pointcloud import OPTIONAL_FIELDS, PointCloud
from ..core.spatial import frames

SCANS_COLLECTION = "WildScan Scans"
MARKER_PROP = "wildscan_pose_marker"
HEADING_PROP = "wildscan_pose_heading"
CLOUD_PROP = "wildscan_cloud"
METADATA_PROP = "wildscan_metadata"
COUNTS_PROP = "wildscan_class_counts"
FRAME_PROP = "wildscan_frame"
SCAN_NUMBER_PROP = "wildscan_scan_number"
WORLD_SEED_PROP = "wildscan_seed"
WORLD_DETAIL_PROP = "wildscan_detail"

MARKER_NAME = "WildScan pose"
HEADING_NAME = "WildScan heading"
DEFAULT_MARKER_SIZE = 1.0  # m, the cross's half-size until the aerial view sizes it to the world

# Per-point attributes of a cloud mesh: (attribute, PointCloud field, Blender type, foreach key, numpy dtype).
CLOUD_ATTRIBUTES = (
    ("wildscan_xyz", "xyz", "FLOAT_VECTOR", "vector", np.float32),
    ("wildscan_label", "label", "INT", "value", np.int32),
    ("wildscan_instance", "instance", "INT", "value", np.int32),
    ("wildscan_intensity", "intensity", "FLOAT", "value", np.float32),
    ("wildscan_ring", "ring", "INT", "value", np.int32),
    ("wildscan_sweep", "sweep", "INT", "value", np.int32),
    ("wildscan_range", "range", "FLOAT", "value", np.float32),
)
# Back to the PointCloud dtypes (pointcloud.py) when a cloud is read for export.
POINTCLOUD_DTYPES = {
    "xyz": np.float64,
    "label": np.uint16,
    "instance": np.uint32,
    "intensity": np.float32,
    "ring": np.uint16,
    "sweep": np.uint16,
    "range": np.float32,
}


# --------------------------------------------------------------------------- lookups


def in_scene(scene, obj) -> bool:
    """Whether `obj` (possibly a dangling or deleted reference) is an object of `scene`."""
    if obj is None:
        return False
    try:
        return scene.objects.get(obj.name) == obj
    except ReferenceError:
        return False


def pose_marker(scene):
    """The scene's pose marker, or None when it has none (never created, or deleted)."""
    settings = getattr(scene, "wildscan", None)
    marker = settings.marker if settings is not None else None
    return marker if in_scene(scene, marker) else None


def world_objects(scene) -> list:
    """The objects of the world WildScan built in this scene (found by their marks,
    whatever its collection is called)."""
    from ..blender.mesh import world_element_objects

    return sorted(world_element_objects(scene), key=lambda o: o.name)


def world_info(scene) -> dict | None:
    """Seed, detail, object count and (endless layout) region of the generated world in the
    scene, if any."""
    from ..blender.mesh import world_root

    objects = world_objects(scene)
    if not objects:
        return None
    root = world_root(scene)
    seed = root.get(WORLD_SEED_PROP) if root is not None else None
    region = root.get("wildscan_region") if root is not None else None
    return {
        "objects": len(objects),
        "seed": int(seed) if seed is not None else None,
        "detail": root.get(WORLD_DETAIL_PROP) if root is not None else None,
        # the region of the endless world built (app/world.py record_region); None: the paper's island
        "region": tuple(float(v) for v in region) if region is not None else None,
    }


def scene_xy_bounds(scene) -> tuple | None:
    """(min xy, max xy, min z, max z) over the world WildScan built, else over every mesh in the scene."""
    objects = world_objects(scene) or [o for o in scene.objects if o.type == "MESH" and not o.get(CLOUD_PROP)]
    corners = []
    for obj in objects:
        if obj.type != "MESH":
            continue
        local = np.array([tuple(c) for c in obj.bound_box], dtype=np.float64)
        m = np.array(obj.matrix_world, dtype=np.float64)
        corners.append(local @ m[:3, :3].T + m[:3, 3])
    if not corners:
        return None
    pts = np.concatenate(corners)
    return pts[:, :2].min(axis=0), pts[:, :2].max(axis=0), pts[:, 2].min(), pts[:, 2].max()


def clouds(scene) -> list:
    """The scan clouds in the scene, oldest first."""
    found = [o for o in scene.objects if o.get(CLOUD_PROP) and o.type == "MESH"]
    return sorted(found, key=lambda o: (int(o.get(SCAN_NUMBER_PROP, 0)), o.name))


def current_cloud(context):
    """The cloud the Result panel and Export talk about: the active object when it is a
    cloud, else the newest cloud of the scene."""
    active = context.view_layer.objects.active if context.view_layer else None
    if active is not None and active.get(CLOUD_PROP) and in_scene(context.scene, active):
        return active
    found = clouds(context.scene)
    return found[-1] if found else None


# --------------------------------------------------------------------------- the pose marker


def ensure_marker(scene, x: float, y: float, yaw_deg: float, z: float = 0.0):
    """The scene's pose marker, created at (x, y, yaw) when missing: an empty drawn as a
    cross (what the user drags) with a child arrow along the heading (not selectable)."""
    settings = scene.wildscan
    marker = pose_marker(scene)
    if marker is None:
        coll = wildscan_collection(SCANS_COLLECTION)
        marker = bpy.data.objects.new(MARKER_NAME, None)
        marker[GENERATED] = True
        marker[MARKER_PROP] = True
        marker.empty_display_type = "PLAIN_AXES"
        marker.show_in_front = True
        marker.show_name = True
        marker.location = (x, y, z)
        marker.rotation_euler = (0.0, 0.0, math.radians(yaw_deg))
        coll.objects.link(marker)
        settings.marker = marker
    heading = ensure_heading(marker)
    set_marker_size(marker, heading, max(marker.empty_display_size, DEFAULT_MARKER_SIZE))
    return marker


def ensure_heading(marker):
    for child in marker.children:
        if child.get(HEADING_PROP):
            return child
    heading = bpy.data.objects.new(HEADING_NAME, None)
    heading[GENERATED] = True
    heading[HEADING_PROP] = True
    heading.empty_display_type = "SINGLE_ARROW"
    heading.show_in_front = True
    heading.hide_select = True  # dragging grabs the cross, never the arrow alone
    heading.parent = marker
    # The arrow points along its local +Z; a quarter turn about Y lays it along the marker's +X (the heading).
    heading.rotation_euler = (0.0, math.pi / 2, 0.0)
    for coll in marker.users_collection:
        coll.objects.link(heading)
    return heading


def set_marker_size(marker, heading, size: float) -> None:
    marker.empty_display_size = size
    if heading is not None:
        heading.empty_display_size = 1.6 * size


def marker_pose(marker) -> tuple[float, float, float]:
    x, y = marker.location[0], marker.location[1]
    return float(x), float(y), math.degrees(marker.rotation_euler[2])


# --------------------------------------------------------------------------- clouds


def _next_scan_number(scene) -> int:
    return 1 + max((int(o.get(SCAN_NUMBER_PROP, 0)) for o in clouds(scene)), default=0)


def _json_safe(value):
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, frozenset, set)):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def cloud_name(metadata: dict) -> str:
    pose = metadata["pose"]
    return f"WildScan scan ({pose['x']:g}, {pose['y']:g}, {pose['yaw_deg']:g})"


def build_cloud_mesh(name: str, cloud: PointCloud, world_xyz: np.ndarray):
    """A mesh of loose vertices at the world positions, with every PLY field as an attribute."""
    mesh = bpy.data.meshes.new(name)
    mesh[GENERATED] = True
    try:
        mesh.vertices.add(len(cloud))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(world_xyz, dtype=np.float32).ravel())
        for attr, field, kind, key, dtype in CLOUD_ATTRIBUTES:
            values = np.ascontiguousarray(getattr(cloud, field), dtype=dtype).ravel()
            mesh.attributes.new(attr, kind, "POINT").data.foreach_set(key, values)
        for name, values in cloud.extra.items():  # the optional fields (pointcloud.OPTIONAL_FIELDS)
            kind, dtype = _extra_attribute(name)
            mesh.attributes.new(f"wildscan_{name}", kind, "POINT").data.foreach_set(
                "value", np.ascontiguousarray(values, dtype=dtype)
            )
        mesh.update()
    except BaseException:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def add_cloud(scene, cloud: PointCloud, metadata: dict, keep_previous: bool = False):
    """Show a scan as a new cloud object in the scans collection; unless `keep_previous`,
    the clouds of earlier scans are removed once the new one exists (they are set aside
    under temporary names meanwhile, so the new one gets its plain name). Nothing else in
    the scene changes, and a failure leaves the earlier clouds as they were."""
    metadata = _json_safe(metadata)
    world_xyz = frames.to_world(cloud.xyz, cloud.frame, metadata["placement"])
    name = cloud_name(metadata)
    old = [] if keep_previous else clouds(scene)
    number = _next_scan_number(scene)
    renamed = []
    mesh = obj = None
    try:
        for i, previous in enumerate(old):
            renamed.append((previous, previous.name))
            previous.name = f".wildscan-replaced-scan-{i}"
        mesh = build_cloud_mesh(name, cloud, world_xyz)
        obj = bpy.data.objects.new(name, mesh)
        obj[GENERATED] = True
        obj[CLOUD_PROP] = True
        obj[FRAME_PROP] = cloud.frame
        obj[SCAN_NUMBER_PROP] = number
        obj[COUNTS_PROP] = {str(k): v for k, v in cloud.class_counts().items()}
        obj[METADATA_PROP] = json.dumps(metadata)
        wildscan_collection(SCANS_COLLECTION).objects.link(obj)
    except BaseException:
        if obj is not None:
            bpy.data.objects.remove(obj)
        if mesh is not None:
            bpy.data.meshes.remove(mesh)
        for previous, previous_name in renamed:
            previous.name = previous_name
        raise
    remove_clouds(old)
    return obj


def remove_clouds(objects) -> None:
    remove_objects_and_their_meshes(objects)


def cloud_metadata(obj) -> dict:
    return json.loads(obj.get(METADATA_PROP, "{}"))


def cloud_counts(obj) -> dict[int, int]:
    counts = obj.get(COUNTS_PROP)
    if counts is None:
        return {}
    return {int(k): int(v) for k, v in counts.to_dict().items()}


def read_cloud(obj) -> PointCloud:
    """The PointCloud a cloud object stores, in the frame it was scanned in."""
    mesh = obj.data
    n = len(mesh.vertices)
    fields = {}
    for attr, field, _kind, key, dtype in CLOUD_ATTRIBUTES:
        data = mesh.attributes.get(attr)
        if data is None or data.domain != "POINT":
            raise ValueError(f"{obj.name} has no point attribute {attr}: it is not a WildScan cloud any more")
        width = 3 if key == "vector" else 1
        values = np.empty(n * width, dtype=dtype)
        data.data.foreach_get(key, values)
        fields[field] = values.reshape(-1, 3) if width == 3 else values
    typed = {f: v.astype(POINTCLOUD_DTYPES[f]) for f, v in fields.items()}
    extra = {}
    for name, code in OPTIONAL_FIELDS:
        data = mesh.attributes.get(f"wildscan_{name}")
        if data is not None and data.domain == "POINT":
            values = np.empty(n, dtype=_extra_attribute(name)[1])
            data.data.foreach_get("value", values)
            extra[name] = values.astype(code)
    return PointCloud(frame=str(obj.get(FRAME_PROP, "leveled")), extra=extra, **typed)


def _extra_attribute(name: str) -> tuple[str, type]:
    """(Blender attribute type, numpy dtype it is set with) of an optional point field."""
    code = dict(OPTIONAL_FIELDS)[name]
    return ("FLOAT", np.float32) if np.dtype(code).kind == "f" else ("INT", np.int32)
