"""The Pose panel's live line: can the robot stand at the current pose, and if not, which
laser hit what. It runs the same placement check as a scan (core.placement.place),
through Blender's own ray cast: a handful of rays, cheap enough for every redraw, and
needing no scene extraction while the user drags the marker.

Results are cached by pose and by a counter that the depsgraph handler bumps whenever
anything but WildScan's own marker and clouds changes, so an unchanged scene is
never re-checked.
"""

from __future__ import annotations

from dataclasses import dataclass

LIVE_BACKEND = "blender"


@dataclass(frozen=True)
class PoseStatus:
    ok: bool
    text: str


_state = {"generation": 0, "key": None, "status": None}


def invalidate() -> None:
    _state["generation"] += 1
    _state["key"] = None


def pose_status(scene) -> PoseStatus:
    from .properties import pose_from, z_start_from

    settings = scene.wildscan
    pose = pose_from(settings)
    z_start = z_start_from(settings)
    key = (scene.name, pose, z_start, _state["generation"])
    if key != _state["key"]:
        _state["status"] = check_pose(pose, z_start)
        _state["key"] = key
        _redraw_viewports()  # the marker's colour shows the new answer
    return _state["status"]


def _redraw_viewports() -> None:
    import bpy

    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas if window.screen is not None else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()


def cached_status(scene) -> PoseStatus | None:
    """The last check's result if it is still the one for the scene's pose (never computes:
    safe from a viewport draw callback)."""
    from .properties import pose_from, z_start_from

    settings = scene.wildscan
    key = (scene.name, pose_from(settings), z_start_from(settings), _state["generation"])
    return _state["status"] if key == _state["key"] else None


def check_pose(pose, z_start) -> PoseStatus:
    """The placement check, as a status (never raises for a user mistake)."""
    from ..app.scan import make_scene_backend
    from ..app.settings import panel_message
    from ..core.errors import UserError
    from ..core.placement import place
    from ..core.sensors import SensorConfig

    try:
        backend = make_scene_backend(LIVE_BACKEND, pose, SensorConfig(), notify=lambda _text: None)
        placement = place(backend, pose, z_start)
    except UserError as e:
        return PoseStatus(False, panel_message(e))
    except Exception as e:  # drawn on every redraw: a bug must show as a line, not a traceback per frame
        return PoseStatus(False, f"Cannot check the pose ({type(e).__name__}: {e})")
    c = placement.optical_centre
    tilt = placement.tilt_deg
    return PoseStatus(
        True,
        f"Valid pose: tilt {tilt:.1f}° (roll {placement.roll_deg:.1f}°, pitch {placement.pitch_deg:.1f}°), "
        f"optical centre at z = {c[2]:.2f} m",
    )


def on_depsgraph_update(scene, depsgraph) -> None:
    """Forget the cached check when anything a placement could see has changed."""
    import bpy

    from .scene import CLOUD_PROP, HEADING_PROP, MARKER_PROP

    for update in depsgraph.updates:
        block = getattr(update.id, "original", None) or update.id
        if isinstance(block, (bpy.types.Scene, bpy.types.WorkSpace, bpy.types.Screen)):
            continue  # settings edits and UI changes; the pose is part of the cache key
        if isinstance(block, bpy.types.Object) and any(
            block.get(p) for p in (MARKER_PROP, HEADING_PROP, CLOUD_PROP)
        ):
            continue
        invalidate()
        return


def invalidate_on_event(*_args) -> None:
    """Handler form of invalidate() (undo, redo and file load pass arguments)."""
    invalidate()
