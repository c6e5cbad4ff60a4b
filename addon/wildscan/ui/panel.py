"""The WildScan tab of the 3D viewport's sidebar (N): World, Pose, Sensor, Scan, Result.

Drawing only reads: every change goes through a property or an operator.
"""

from __future__ import annotations

import textwrap

from bpy.types import Panel

CATEGORY = "WildScan"
CHAR_PX = 6.8  # rough width of a character of the UI font at scale 1, to wrap long lines
TEXT_MARGIN_PX = 48  # panel margins, box and icon
TWO_COLUMN_LEGEND_PX = 330  # sidebar width (at scale 1) from which the legend uses two columns


def region_width(context) -> float:
    """The sidebar's width in unscaled UI pixels."""
    width = context.region.width if context.region is not None else 300
    return width / max(0.5, context.preferences.system.ui_scale)


def wrapped(layout, context, text: str, icon: str = "NONE") -> None:
    """Long text as several labels (a label never wraps by itself)."""
    width = max(16, int((region_width(context) - TEXT_MARGIN_PX) / CHAR_PX))
    lines = textwrap.wrap(text, width) or [""]
    col = layout.column(align=True)
    for i, line in enumerate(lines):
        col.label(text=line, icon=icon if i == 0 else "BLANK1" if icon != "NONE" else "NONE")


class _WildScanPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY

    @classmethod
    def poll(cls, context):
        return context.scene is not None and hasattr(context.scene, "wildscan")


class VIEW3D_PT_wildscan_world(_WildScanPanel, Panel):
    bl_label = "World"
    bl_order = 0

    def draw(self, context):
        from .scene import world_info

        s = context.scene.wildscan
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(s, "seed")
        layout.prop(s, "detail")
        layout.prop(s, "vegetation")
        layout.prop(s, "biome")
        layout.prop(s, "world_layout")
        if s.world_layout == "endless":
            col = layout.column(align=True)
            col.prop(s, "region_x")
            col.prop(s, "region_y")
            col.prop(s, "region_size")
        layout.operator("wildscan.generate_world", icon="WORLD")
        info = world_info(context.scene)
        if info is None:
            layout.label(text="No world yet", icon="INFO")
        else:
            seed = f"seed {info['seed']}" if info["seed"] is not None else "world"
            layout.label(text=f"{seed}: {info['objects']} objects", icon="CHECKMARK")
            if info.get("region") is not None:
                x0, y0, x1, y1 = info["region"]
                layout.label(text=f"region {x0:g} {y0:g} {x1:g} {y1:g}")
                layout.operator("wildscan.extend_region", icon="FULLSCREEN_ENTER")


class VIEW3D_PT_wildscan_pose(_WildScanPanel, Panel):
    bl_label = "Pose"
    bl_order = 1

    def draw(self, context):
        from .scene import pose_marker
        from .status import pose_status

        s = context.scene.wildscan
        layout = self.layout
        row = layout.row(align=True)
        row.operator("wildscan.aerial_view", icon="VIEW_ORTHO")
        marker = pose_marker(context.scene)
        if marker is None:
            row.operator("wildscan.add_pose_marker", text="", icon="EMPTY_AXIS")
        col = layout.column(align=True)
        col.use_property_split = True
        col.use_property_decorate = False
        col.prop(s, "pose_x")
        col.prop(s, "pose_y")
        col.prop(s, "pose_yaw", text="Yaw (deg)")
        row = layout.row(align=True)
        row.prop(s, "use_z_start")
        sub = row.row(align=True)
        sub.active = s.use_z_start
        sub.prop(s, "z_start", text="")
        if marker is None:
            wrapped(layout, context, "Aerial view adds the pose marker to drag", icon="INFO")
        state = pose_status(context.scene)
        box = layout.box()
        box.alert = not state.ok
        wrapped(box, context, state.text, icon="CHECKMARK" if state.ok else "ERROR")


class VIEW3D_PT_wildscan_sensor(_WildScanPanel, Panel):
    bl_label = "Sensor"
    bl_order = 2

    def draw(self, context):
        from ..app.settings import panel_message
        from ..core.errors import UserError
        from .device import FILE_CHOICE
        from .properties import device_limits_text, sensor_from
        from .weather import draw_effects, draw_weather, effects_from, weather_from

        s = context.scene.wildscan
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(s, "device")
        if s.device == FILE_CHOICE:
            layout.prop(s, "sensor_file")
        col = layout.column(align=True)
        col.prop(s, "rh", text="r_h (deg)")
        col.prop(s, "min_range")
        col.prop(s, "max_range")
        col.prop(s, "mount_height")
        hint = device_limits_text(s)
        if hint:
            layout.label(text=hint)
        layout.prop(s, "model")
        realistic = s.model == "realistic"
        if realistic:
            col = layout.column(align=True)
            col.prop(s, "divergence", text="Divergence (mrad)")
            col.prop(s, "datasheet_noise")
        col = layout.column(align=True)
        row = col.row()
        row.active = not (realistic and s.datasheet_noise)
        row.prop(s, "noise")
        col.prop(s, "noise_seed")
        layout.prop(s, "frame")
        draw_weather(layout, s)
        draw_effects(layout, s)
        try:
            weather_from(s)
            effects_from(s)
            sensor = sensor_from(s).validate()
        except UserError as e:
            box = layout.box()
            box.alert = True
            wrapped(box, context, panel_message(e), icon="ERROR")
        else:
            what = f"{sensor.device.name}: {sensor.beam_count:,} beams in {sensor.sweeps} 2D scans"
            wrapped(layout, context, what, icon="INFO")


class VIEW3D_PT_wildscan_scan(_WildScanPanel, Panel):
    bl_label = "Scan"
    bl_order = 3

    def draw(self, context):
        s = context.scene.wildscan
        layout = self.layout
        row = layout.row(align=True)
        row.scale_y = 1.4
        row.operator("wildscan.scan", icon="PLAY")
        row.operator("wildscan.export_scan", icon="EXPORT")
        col = layout.column(align=True)
        col.use_property_split = True
        col.use_property_decorate = False
        col.prop(s, "backend")
        layout.prop(s, "keep_previous")


class VIEW3D_PT_wildscan_result(_WildScanPanel, Panel):
    bl_label = "Result"
    bl_order = 4

    def draw(self, context):
        from .scene import cloud_counts, cloud_metadata, current_cloud

        layout = self.layout
        s = context.scene.wildscan
        obj = current_cloud(context)
        if obj is None:
            layout.label(text="No scan yet: press Scan", icon="INFO")
            return
        meta = cloud_metadata(obj)
        counts = cloud_counts(obj)
        layout.label(text=obj.name, icon="OUTLINER_OB_POINTCLOUD")
        placement = meta.get("placement") or {}
        if placement:
            wrapped(
                layout,
                context,
                f"{meta.get('frame', '?')} frame; roll {placement['roll_deg']:.1f}°, "
                f"pitch {placement['pitch_deg']:.1f}°",
            )
        draw_legend(layout, counts, columns=2 if region_width(context) >= TWO_COLUMN_LEGEND_PX else 1)
        untagged = meta.get("untagged_objects_hit") or []
        if untagged:
            box = layout.box()
            box.alert = True
            wrapped(
                box,
                context,
                f"{len(untagged)} untagged object(s) hit, labeled 0: {', '.join(untagged[:3])}",
                icon="ERROR",
            )
        row = layout.row(align=True)
        row.prop(s, "show_world", toggle=True, icon="WORLD")
        row.prop(s, "points_in_front", toggle=True)
        layout.prop(s, "point_size", slider=True)


def draw_legend(layout, counts: dict[int, int], columns: int) -> None:
    """One line per class in the cloud: its colour, id, name and point count; then the total."""
    from ..core.classes import BY_ID
    from . import legend

    entries = [
        (cid, BY_ID[cid].name if cid in BY_ID else f"class {cid}", n) for cid, n in sorted(counts.items())
    ]
    entries.append((None, "total", sum(counts.values())))
    rows = -(-len(entries) // columns)
    grid = layout.grid_flow(row_major=False, columns=columns, even_columns=True, align=True)
    for k in range(rows * columns):
        cell = grid.row(align=True)
        if k >= len(entries):
            cell.label(text="")
            continue
        class_id, name, n = entries[k]
        split = cell.split(factor=0.6, align=True)
        icon_value = legend.icon_id(class_id) if class_id is not None else 0
        text = f"{name}" if class_id is None else f"{class_id} {name}"
        if icon_value:
            split.label(text=text, icon_value=icon_value)
        else:
            split.label(text=text, icon="BLANK1")
        split.label(text=f"{n:,}")


CLASSES = (
    VIEW3D_PT_wildscan_world,
    VIEW3D_PT_wildscan_pose,
    VIEW3D_PT_wildscan_sensor,
    VIEW3D_PT_wildscan_scan,
    VIEW3D_PT_wildscan_result,
)
