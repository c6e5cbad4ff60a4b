"""The add-on's operators. Thin: they read `scene.wildscan`, call the same functions as
the `wildscan` command and show the outcome.

Scripting: set `bpy.context.scene.wildscan.<setting>`, then call
bpy.ops.wildscan.generate_world(), .aerial_view(), .scan(), .export_scan(filepath=..., format=...)
(formats: core/io/formats.py; .export_ply(filepath=...) is export_scan for PLY only).

Every operator checks what the user could get wrong before it changes anything; a
mistake is one ERROR report (RuntimeError for a script) and the scene is left as it
was. Logic imports are lazy (inside execute), as in Blender's own add-ons.
"""

import os

import bpy
from bpy.props import BoolProperty, EnumProperty, StringProperty
from bpy.types import Operator
from bpy_extras.io_utils import ExportHelper

from ..app.settings import panel_message
from .feedback import Progress, internal_error, tag_view3d_redraw

AERIAL_MARGIN = 1.15  # the aerial view shows the world with this much room around it
MARKER_SIZE_OF_WORLD = 0.04  # the marker's cross spans this fraction of the world's extent each way
MIN_MARKER_SIZE = 0.5  # m
DEFAULT_EXPORT_STEM = "wildscan_scan"


def view3d_area(context):
    """The 3D viewport to switch: the one the operator runs in, else the largest of the screen."""
    if context.area is not None and context.area.type == "VIEW_3D":
        return context.area
    screens = (
        [context.screen] if context.screen is not None else [w.screen for w in context.window_manager.windows]
    )
    areas = [a for s in screens if s is not None for a in s.areas if a.type == "VIEW_3D"]
    return max(areas, key=lambda a: a.width * a.height, default=None)


def _world_seed(scene):
    from .scene import world_info

    info = world_info(scene)
    return info["seed"] if info else None


class WILDSCAN_OT_generate_world(Operator):
    bl_idname = "wildscan.generate_world"
    bl_label = "Generate"
    bl_description = (
        "Build the world of this seed; replaces only what WildScan built before (your objects stay)"
    )
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from ..app.world import build_in_scene
        from ..core.errors import UserError
        from . import status
        from .scene import world_info

        settings = context.scene.wildscan
        seed, detail, vegetation = int(settings.seed), str(settings.detail), str(settings.vegetation)
        biome = str(settings.biome)
        try:
            with Progress(context, f"WildScan: building the world of seed {seed}") as progress:
                if settings.world_layout == "endless":
                    from .region import build_region, panel_region

                    build_region(seed, panel_region(settings), detail, progress.stage, vegetation, biome)
                else:
                    build_in_scene(seed, detail, progress.stage, vegetation=vegetation, biome=biome)
        except UserError as e:
            self.report({"ERROR"}, panel_message(e))
            return {"CANCELLED"}
        except Exception as e:
            return internal_error(self, f"building the world of seed {seed}", e)
        finally:
            status.invalidate()
        info = world_info(context.scene)
        count = info["objects"] if info else 0
        self.report({"INFO"}, f"Built the world of seed {seed} ({detail} detail): {count} objects")
        tag_view3d_redraw(context)
        return {"FINISHED"}


class WILDSCAN_OT_add_pose_marker(Operator):
    bl_idname = "wildscan.add_pose_marker"
    bl_label = "Add pose marker"
    bl_description = "Add the pose marker at the current pose: drag it to choose where the robot stands"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from .scene import ensure_marker

        s = context.scene.wildscan
        marker = ensure_marker(context.scene, s.pose_x, s.pose_y, s.pose_yaw)
        _select_only_marker(context, marker)
        tag_view3d_redraw(context)
        return {"FINISHED"}


def _select_only_marker(context, marker) -> None:
    """Make the marker selected and active so the next G drags it (other objects' selection is
    left alone). Skipped when the marker is not in the view layer (its collection excluded)."""
    view_layer = context.view_layer
    if view_layer is None:
        return
    try:
        marker.select_set(True, view_layer=view_layer)
        view_layer.objects.active = marker
    except (RuntimeError, ValueError):
        pass


class WILDSCAN_OT_aerial_view(Operator):
    bl_idname = "wildscan.aerial_view"
    bl_label = "Aerial view"
    bl_description = (
        "Look straight down on the whole world (orthographic, objects in their class colours) with the "
        "pose marker drawn as a large cross: drag it (G) to choose where the robot stands"
    )
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from .scene import ensure_heading, ensure_marker, scene_xy_bounds, set_marker_size

        scene = context.scene
        bounds = scene_xy_bounds(scene)
        if bounds is None:
            self.report({"ERROR"}, "Nothing to look at: generate a world first (World > Generate)")
            return {"CANCELLED"}
        area = view3d_area(context)
        if area is None:
            self.report({"ERROR"}, "The aerial view needs a 3D viewport in this window")
            return {"CANCELLED"}
        lo, hi, z_min, z_max = bounds
        extent = float(max(hi - lo))
        s = scene.wildscan
        marker = ensure_marker(scene, s.pose_x, s.pose_y, s.pose_yaw)
        set_marker_size(marker, ensure_heading(marker), max(MIN_MARKER_SIZE, MARKER_SIZE_OF_WORLD * extent))
        _select_only_marker(context, marker)
        show_from_above(context, area, (lo + hi) / 2.0, extent, z_min, z_max)
        tag_view3d_redraw(context)
        return {"FINISHED"}


def show_from_above(context, area, centre_xy, extent: float, z_min: float, z_max: float) -> None:
    """Top orthographic view of a square of side `extent` around `centre_xy`."""

    space = area.spaces.active
    r3d = space.region_3d
    region = next((r for r in area.regions if r.type == "WINDOW"), None)
    w, h = (
        (region.width, region.height)
        if region is not None and region.width > 1
        else (area.width, area.height)
    )
    aspect = max(w, h) / max(1, min(w, h))
    set_top_view(context, area, region, r3d)
    # A non-camera orthographic viewport spans dist * 72 / lens along its longer side
    # (sensor width 36 mm, zoom factor 2): fit the world into the shorter side.
    r3d.view_perspective = "ORTHO"
    r3d.view_location = (float(centre_xy[0]), float(centre_xy[1]), float((z_min + z_max) / 2))
    r3d.view_distance = AERIAL_MARGIN * extent * space.lens / 72.0 * aspect
    depth = float(z_max - z_min) + 2.0 * r3d.view_distance
    if space.clip_end < depth:
        space.clip_end = depth
    if space.shading.type == "SOLID":
        space.shading.color_type = (
            "OBJECT"  # world objects carry their class colour (blender.mesh.tag_object)
        )


def set_top_view(context, area, region, r3d) -> None:
    """Blender's own Top view (so the viewport says "Top Orthographic" and numpad keys carry on
    from there), without the smooth-view animation that would undo the framing set next.
    Without a window (background mode) the rotation alone is set."""
    from mathutils import Quaternion

    prefs = context.preferences.view
    if context.window is not None and region is not None:
        smooth = prefs.smooth_view
        prefs.smooth_view = 0
        try:
            with context.temp_override(area=area, region=region):
                bpy.ops.view3d.view_axis(type="TOP")
            return
        except (RuntimeError, TypeError):
            pass  # fall back to setting the rotation
        finally:
            prefs.smooth_view = smooth
    r3d.view_rotation = Quaternion((1.0, 0.0, 0.0, 0.0))  # looking down -Z with +Y up


class WILDSCAN_OT_scan(Operator):
    bl_idname = "wildscan.scan"
    bl_label = "Scan"
    bl_description = (
        "Stand the emulated Hokuyo UTM-30LX-EW at the pose and scan the scene; the labeled cloud "
        "appears as one object in the 'WildScan Scans' collection (nothing else changes)"
    )
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from ..app.scan import scan_current_scene
        from ..core.errors import UserError
        from ..core.spatial.frames import check_frame
        from ..raycast.select import check_backend_name
        from . import status
        from .properties import pose_from, sensor_from, z_start_from
        from .scene import add_cloud, pose_marker
        from .weather import effects_from, weather_from

        scene = context.scene
        settings = scene.wildscan
        notes: list[str] = []
        try:
            sensor = sensor_from(settings).validate()
            pose = pose_from(settings).validate()
            z_start = z_start_from(settings)
            frame = check_frame(settings.frame)
            backend = check_backend_name(settings.backend)
            weather = weather_from(settings)
            effects = effects_from(settings)
            with Progress(context, "WildScan: scanning") as progress:
                result = scan_current_scene(
                    pose,
                    sensor,
                    frame,
                    z_start,
                    backend,
                    progress=progress.scan,
                    notify=notes.append,
                    weather=weather,
                    effects=effects,
                )
            metadata = dict(result.metadata, seed=_world_seed(scene), world=bpy.data.filepath or None)
            obj = add_cloud(scene, result.cloud, metadata, keep_previous=settings.keep_previous)
        except UserError as e:
            self.report({"ERROR"}, panel_message(e))
            return {"CANCELLED"}
        except Exception as e:
            return internal_error(self, "scanning", e)
        marker = pose_marker(scene)
        if marker is not None:
            marker.location[2] = float(result.placement.ground_centre[2])  # stand the cross on the ground
        status.invalidate()
        for note in notes:
            self.report({"INFO"}, note)
        if result.untagged_objects:
            names = ", ".join(sorted(result.untagged_objects)[:5])
            self.report(
                {"WARNING"},
                f"{len(result.untagged_objects)} untagged object(s) hit ({names}): their "
                "points are labeled 0 (unlabeled); tag them in the Tag panel",
            )
        self.report(
            {"INFO"},
            f"Scanned {len(result.cloud):,} points of {result.beams:,} beams "
            f"({frame} frame) into '{obj.name}'",
        )
        from .region import reach_warning

        warning = reach_warning(scene, pose, sensor)
        if warning:
            self.report({"WARNING"}, warning)
        tag_view3d_redraw(context)
        return {"FINISHED"}


def _format_items():
    """The Format menu: the table's formats (core/io/formats.py), the default first."""
    from ..core.io.formats import DEFAULT_FORMAT, WRITERS

    names = sorted(WRITERS, key=lambda name: name != DEFAULT_FORMAT)  # stable: the table's order after
    return [(name, WRITERS[name].title, WRITERS[name].writes) for name in names]


def _scan_file_globs() -> str:
    from ..core.io.formats import WRITERS

    return ";".join(sorted({f"*{w.suffix}" for w in WRITERS.values()}))


class _ExportScan:
    """What the export operators share (a mixin: Blender refuses a subclass of a registered
    operator); each declares its own `format` and `filter_glob`."""

    bl_options = {"REGISTER"}
    filename_ext = ".ply"  # ExportHelper's; `check` follows the chosen format instead
    ascii: BoolProperty(
        name="ASCII", description="PLY only: an ASCII PLY instead of binary little-endian", default=False
    )

    def invoke(self, context, event):
        from ..core.io.formats import WRITERS
        from .scene import current_cloud

        if current_cloud(context) is None:
            self.report({"ERROR"}, "No scan to export: press Scan first")
            return {"CANCELLED"}
        if not self.filepath:
            folder = os.path.dirname(bpy.data.filepath) if bpy.data.filepath else ""
            self.filepath = os.path.join(folder, DEFAULT_EXPORT_STEM + WRITERS[self.format].suffix)
        return ExportHelper.invoke(self, context, event)

    def check(self, context):
        """In the file browser: the file name takes the chosen format's suffix."""
        from ..core.io.formats import WRITERS

        stem, suffix = os.path.splitext(self.filepath)
        wanted = WRITERS[self.format].suffix
        if not os.path.basename(stem) or suffix.lower() == wanted:
            return False
        self.filepath = stem + wanted
        return True

    def execute(self, context):
        from ..core.errors import UserError
        from ..core.io import formats
        from .scene import current_cloud

        obj = current_cloud(context)
        if obj is None:
            self.report({"ERROR"}, "No scan to export: press Scan first")
            return {"CANCELLED"}
        try:
            w = formats.writer(self.format)
            formats.check_ascii(w, self.ascii)
            out = formats.check_scan_output(w, bpy.path.abspath(self.filepath))
            cloud, metadata = cloud_for_export(obj, context.scene.wildscan.frame)
            first, *beside = formats.write_scan(w, formats.single_scan(w, cloud, metadata, self.ascii), out)
        except UserError as e:
            self.report({"ERROR"}, panel_message(e))
            return {"CANCELLED"}
        except Exception as e:
            return internal_error(self, "exporting the scan", e)
        also = f" and {', '.join(p.name for p in beside)}" if beside else ""
        self.report({"INFO"}, f"Wrote {first} ({len(cloud):,} points, {cloud.frame} frame){also}")
        return {"FINISHED"}


class WILDSCAN_OT_export_scan(_ExportScan, Operator, ExportHelper):
    bl_idname = "wildscan.export_scan"
    bl_label = "Export"
    bl_description = (
        "Write the scan's labeled point cloud in the chosen format and frame: PLY (plus its JSON "
        "sidecar), LAS 1.4 or SemanticKITTI (.bin + .label beside it)"
    )

    filter_glob: StringProperty(default=_scan_file_globs(), options={"HIDDEN"})
    format: EnumProperty(name="Format", description="File format", items=_format_items(), default="ply")


class WILDSCAN_OT_export_ply(_ExportScan, Operator, ExportHelper):
    """export_scan for PLY only, under the name scripts have called since the first release."""

    bl_idname = "wildscan.export_ply"
    bl_label = "Export PLY"
    bl_description = (
        "Write the scan's labeled point cloud to a PLY file (plus its JSON sidecar) in the chosen frame"
    )

    filter_glob: StringProperty(default="*.ply", options={"HIDDEN"})
    format: EnumProperty(name="Format", items=[("ply", "PLY", "PLY and its JSON sidecar")], default="ply")


def cloud_for_export(obj, frame: str):
    """(PointCloud, metadata) of a cloud object in `frame`: as scanned when it is the frame of
    the scan, else moved with the scan's placement (metadata records both)."""
    from ..core.spatial import frames
    from .scene import cloud_metadata, read_cloud

    frames.check_frame(frame)
    cloud = read_cloud(obj)
    metadata = cloud_metadata(obj)
    if cloud.frame != frame:
        cloud.xyz = frames.convert(cloud.xyz, cloud.frame, frame, metadata["placement"])
        metadata["converted_from_frame"] = cloud.frame
        cloud.frame = frame
        metadata["frame"] = frame
    return cloud, metadata


CLASSES = (
    WILDSCAN_OT_generate_world,
    WILDSCAN_OT_add_pose_marker,
    WILDSCAN_OT_aerial_view,
    WILDSCAN_OT_scan,
    WILDSCAN_OT_export_scan,
    WILDSCAN_OT_export_ply,
)
