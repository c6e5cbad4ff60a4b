"""Drawing in the 3D viewport (gpu module): scan clouds as points in their class colours,
and the pose marker as a bold cross coloured by the live pose check.

A cloud is a mesh of loose vertices, which Blender itself does not draw in object
mode, so a POST_VIEW draw handler draws every visible cloud object of the scene
(respecting the overlays toggle, the object's visibility and transform).

Shader names: Blender 4.0+ has POINT_FLAT_COLOR (round points whose pixel size is
its `size` uniform, on every GPU backend); 3.4 has FLAT_COLOR with the point size of
gpu.state.point_size_set. Lines: POLYLINE_UNIFORM_COLOR in both. Shaders are created
lazily inside the draw callback: there is no GPU in background mode.

Batches are cached per cloud, keyed by the mesh's address, its vertex count and the
object's matrix; the cache is emptied on undo, redo and file load, when datablocks
may be re-allocated at the same address.
"""

from __future__ import annotations

import math
import sys

import bpy
import numpy as np

from ..core.classes import COLOR_BY_ID
from .scene import CLOUD_ATTRIBUTES, CLOUD_PROP

_LABEL_ATTRIBUTE = CLOUD_ATTRIBUTES[1][0]
_state = {
    "handle": None,
    "shader": None,
    "shader_name": None,
    "line_shader": None,
    "batches": {},
    "failed": False,
}
MARKER_OK_RGBA = (0.2, 1.0, 0.3, 1.0)
MARKER_BAD_RGBA = (1.0, 0.15, 0.1, 1.0)
MARKER_UNKNOWN_RGBA = (1.0, 1.0, 1.0, 1.0)
MARKER_LINE_PX = 3.0


def _shader():
    if _state["shader"] is None:
        import gpu

        for name in ("POINT_FLAT_COLOR", "FLAT_COLOR", "3D_FLAT_COLOR"):
            try:
                _state["shader"] = gpu.shader.from_builtin(name)
                _state["shader_name"] = name
                break
            except (ValueError, TypeError):
                continue
    return _state["shader"]


def _line_shader():
    if _state["line_shader"] is None:
        import gpu

        for name in ("POLYLINE_UNIFORM_COLOR", "3D_POLYLINE_UNIFORM_COLOR"):
            try:
                _state["line_shader"] = gpu.shader.from_builtin(name)
                break
            except (ValueError, TypeError):
                continue
    return _state["line_shader"]


def marker_lines(x: float, y: float, z: float, yaw_deg: float, size: float) -> np.ndarray:
    """(2K,3) float32 segment ends of the pose cross: a long arm with an arrowhead along the
    heading, a short one behind, and the cross arm."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    local = (
        np.array(
            [
                [0, 0],
                [1.6, 0],  # heading
                [1.6, 0],
                [1.25, 0.25],
                [1.6, 0],
                [1.25, -0.25],  # arrowhead
                [0, 0],
                [-1.0, 0],  # behind
                [0, -1.0],
                [0, 1.0],  # across
            ],
            dtype=np.float64,
        )
        * size
    )
    world = local @ np.array([[c, s], [-s, c]]) + [x, y]
    return np.column_stack([world, np.full(len(world), z)]).astype(np.float32)


def draw_marker(context, scene) -> None:
    """The pose marker as a bold cross on top of everything, green where the robot can stand,
    red where it cannot (the Pose panel's live line says why)."""
    import gpu
    from gpu_extras.batch import batch_for_shader

    from . import status
    from .scene import marker_pose, pose_marker

    marker = pose_marker(scene)
    if marker is None or not marker.visible_get():
        return
    shader = _line_shader()
    region = context.region
    if shader is None or region is None:
        return
    state = status.cached_status(scene)
    rgba = MARKER_UNKNOWN_RGBA if state is None else MARKER_OK_RGBA if state.ok else MARKER_BAD_RGBA
    x, y, yaw = marker_pose(marker)
    lines = marker_lines(
        x, y, float(marker.matrix_world.translation.z), yaw, float(marker.empty_display_size)
    )
    batch = batch_for_shader(shader, "LINES", {"pos": lines})
    shader.bind()
    shader.uniform_float("viewportSize", (float(region.width), float(region.height)))
    for width, colour in ((MARKER_LINE_PX + 2.0, (0.0, 0.0, 0.0, 1.0)), (MARKER_LINE_PX, rgba)):
        shader.uniform_float("lineWidth", width)
        shader.uniform_float("color", colour)
        batch.draw(shader)
    gpu.state.line_width_set(1.0)


def cloud_arrays(obj) -> tuple[np.ndarray, np.ndarray]:
    """(N,3) float32 world positions and (N,4) float32 RGBA colours of a cloud object."""
    mesh = obj.data
    n = len(mesh.vertices)
    co = np.empty(n * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world, dtype=np.float64)
    pos = (co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
    labels = np.zeros(n, dtype=np.int32)
    attr = mesh.attributes.get(_LABEL_ATTRIBUTE)
    if attr is not None and attr.domain == "POINT" and attr.data_type == "INT":
        attr.data.foreach_get("value", labels)
    labels = np.clip(labels, 0, len(COLOR_BY_ID) - 1)
    rgba = np.ones((n, 4), dtype=np.float32)
    rgba[:, :3] = COLOR_BY_ID[labels] / 255.0
    return pos, rgba


RIM_RGBA = (0.05, 0.05, 0.05, 1.0)  # dark rim around each point: readable on surfaces of its own colour


def _batches(obj, shader):
    """(rim batch, colour batch) of a cloud object, cached."""
    from gpu_extras.batch import batch_for_shader

    key = (obj.data.as_pointer(), len(obj.data.vertices), tuple(map(tuple, obj.matrix_world)))
    cached = _state["batches"].get(obj.name)
    if cached is not None and cached[0] == key:
        return cached[1]
    pos, rgba = cloud_arrays(obj)
    rim = np.empty_like(rgba)
    rim[:] = RIM_RGBA
    batches = (
        batch_for_shader(shader, "POINTS", {"pos": pos, "color": rim}),
        batch_for_shader(shader, "POINTS", {"pos": pos, "color": rgba}),
    )
    _state["batches"][obj.name] = (key, batches)
    return batches


def draw_clouds() -> None:
    context = bpy.context
    space = context.space_data
    scene = context.scene
    if _state["failed"] or scene is None or getattr(scene, "wildscan", None) is None:
        return
    if space is not None and hasattr(space, "overlay") and not space.overlay.show_overlays:
        return
    objects = [o for o in scene.objects if o.get(CLOUD_PROP) and o.type == "MESH" and o.visible_get()]
    try:
        import gpu

        if objects:
            _draw_points(gpu, scene, objects)
        gpu.state.depth_test_set("NONE")
        draw_marker(context, scene)
    except Exception as e:  # a drawing bug must not spam a traceback on every redraw
        _state["failed"] = True
        sys.stderr.write(
            f"WildScan: cannot draw scan clouds ({type(e).__name__}: {e}); drawing is off until "
            "the add-on is enabled again\n"
        )
    finally:
        try:
            import gpu

            gpu.state.depth_test_set("NONE")
            gpu.state.point_size_set(1.0)
        except Exception:
            pass


def _draw_points(gpu, scene, objects) -> None:
    shader = _shader()
    settings = scene.wildscan
    gpu.state.depth_test_set("NONE" if settings.points_in_front else "LESS_EQUAL")
    pairs = [_batches(obj, shader) for obj in objects]
    # A dark rim first, then the colour: points stay readable on surfaces of their own colour.
    sized_by_uniform = _state["shader_name"].startswith("POINT_")  # 4.0+: a `size` uniform, in pixels
    for size, which in ((settings.point_size + 2, 0), (settings.point_size, 1)):
        if sized_by_uniform:
            shader.bind()
            shader.uniform_float("size", float(size))
        else:
            gpu.state.point_size_set(float(size))
        for pair in pairs:
            pair[which].draw(shader)
    if len(_state["batches"]) > len(objects):
        names = {o.name for o in objects}
        _state["batches"] = {k: v for k, v in _state["batches"].items() if k in names}


def forget_batches(*_args) -> None:
    _state["batches"].clear()


def register() -> None:
    _state.update(failed=False, batches={})
    if _state["handle"] is None:
        _state["handle"] = bpy.types.SpaceView3D.draw_handler_add(draw_clouds, (), "WINDOW", "POST_VIEW")


def unregister() -> None:
    if _state["handle"] is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_state["handle"], "WINDOW")
        _state["handle"] = None
    _state.update(shader=None, line_shader=None, batches={})
