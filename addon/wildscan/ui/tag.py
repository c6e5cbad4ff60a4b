"""The Tag section of the add-on: give users' own objects a WildScan class, see each
object's tag, and list the meshes a scan would label 0 (bpy).

Tagging writes the same custom properties a user can type (`wildscan_class`,
`wildscan_instance`; core/classes.py), so a tagged scene scans the same from the
panel, the command line and a script. Instance ids are assigned automatically:
an object keeps an id no other object in the scene uses, else gets the next free
one above the largest in use, so ids stay unique in the scene.
"""

from __future__ import annotations

from bpy.props import EnumProperty
from bpy.types import Operator, Panel

from ..blender.mesh import tag_object
from ..core.classes import CLASS_PROP, INSTANCE_PROP, MAX_INSTANCE, REFLECTIVITY_PROP, TAG_NAMES
from ..raycast.extract import MESH_TYPES, singular
from .panel import CATEGORY, wrapped
from .scene import CLOUD_PROP

CLASS_ITEMS = [(name, name.capitalize(), f"Tag as {name}") for name in TAG_NAMES]
UNTAGGED_SHOWN = 8  # the panel lists this many untagged meshes, then a count


def scanned_objects(scene) -> list:
    """The scene's own mesh-like objects a scan sees (docs/scanning.md "Which objects a scan sees"),
    WildScan's scan clouds aside."""
    return [
        o
        for o in scene.objects
        if o.type in MESH_TYPES and not o.get(CLOUD_PROP) and o.visible_get() and not singular(o.matrix_world)
    ]


def untagged_meshes(scene) -> list:
    """The objects a scan sees that carry no `wildscan_class`: their points are labeled 0."""
    return sorted((o for o in scanned_objects(scene) if o.get(CLASS_PROP) is None), key=lambda o: o.name)


def _whole(value) -> int | None:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    return (
        value
        if isinstance(value, int) and not isinstance(value, bool) and 0 < value <= MAX_INSTANCE
        else None
    )


def tag_objects(scene, objects, class_name: str) -> int:
    """Give `objects` (their mesh-like ones) the class `class_name` and instance ids unique
    in the scene; returns how many were tagged."""
    targets = [o for o in objects if o.type in MESH_TYPES and not o.get(CLOUD_PROP)]
    chosen = set(targets)
    taken: dict[int, int] = {}
    for o in scene.objects:
        if o not in chosen and _whole(o.get(INSTANCE_PROP)) is not None:
            taken[_whole(o.get(INSTANCE_PROP))] = 1
    next_free = max(taken, default=0) + 1
    for obj in sorted(targets, key=lambda o: o.name):
        own = _whole(obj.get(INSTANCE_PROP))
        if own is None or own in taken:
            own, next_free = next_free, next_free + 1
        taken[own] = 1
        next_free = max(next_free, own + 1)
        tag_object(obj, class_name, own)
    return len(targets)


def tag_text(obj) -> str:
    """One line: the object's class, instance and reflectivity override as tagged."""
    cls = obj.get(CLASS_PROP)
    if cls is None:
        return f"{obj.name}: untagged (labeled 0)"
    text = f"{obj.name}: {cls}, instance {obj.get(INSTANCE_PROP, '-')}"
    refl = obj.get(REFLECTIVITY_PROP)
    return text + (f", reflectivity {refl}" if refl is not None else "")


class WILDSCAN_OT_tag(Operator):
    bl_idname = "wildscan.tag"
    bl_label = "Tag"
    bl_description = "Set the WildScan class of the selected objects or of the active collection's objects"
    bl_options = {"REGISTER", "UNDO"}

    class_name: EnumProperty(name="Class", items=CLASS_ITEMS)
    target: EnumProperty(
        name="Objects",
        items=[
            ("SELECTED", "Selected", "The selected objects"),
            ("COLLECTION", "Collection", "Every object of the active collection and its children"),
        ],
    )

    def execute(self, context):
        if self.target == "SELECTED":
            objects = list(context.selected_objects)
        else:
            coll = context.collection
            objects = list(coll.all_objects) if coll is not None else []
        n = tag_objects(context.scene, objects, self.class_name)
        if not n:
            self.report({"WARNING"}, "No mesh to tag: select objects (or activate a collection) first")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Tagged {n} object(s) as {self.class_name}")
        return {"FINISHED"}


class WILDSCAN_OT_select_untagged(Operator):
    bl_idname = "wildscan.select_untagged"
    bl_label = "Select untagged"
    bl_description = "Select the meshes a scan sees that have no WildScan class (their points are labeled 0)"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        found = untagged_meshes(context.scene)
        for obj in context.selected_objects:
            obj.select_set(False)
        for obj in found:
            obj.select_set(True)
        if found:
            context.view_layer.objects.active = found[0]
        self.report({"INFO"}, f"{len(found)} untagged mesh(es)")
        return {"FINISHED"}


class VIEW3D_PT_wildscan_tag(Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY
    bl_label = "Tag"
    bl_order = 5
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.scene is not None and hasattr(context.scene, "wildscan")

    def draw(self, context):
        layout = self.layout
        s = context.scene.wildscan
        layout.prop(s, "tag_class")
        row = layout.row(align=True)
        for target, text in (("SELECTED", "Tag selected"), ("COLLECTION", "Tag collection")):
            op = row.operator(WILDSCAN_OT_tag.bl_idname, text=text)
            op.class_name, op.target = s.tag_class, target
        active = context.active_object
        if active is not None:
            wrapped(layout, context, tag_text(active), icon="OBJECT_DATA")
        untagged = untagged_meshes(context.scene)
        if not untagged:
            layout.label(text="Every mesh a scan sees is tagged", icon="CHECKMARK")
            return
        box = layout.box()
        box.alert = True
        box.label(text=f"{len(untagged)} untagged mesh(es), labeled 0:", icon="ERROR")
        col = box.column(align=True)
        for obj in untagged[:UNTAGGED_SHOWN]:
            col.label(text=obj.name, icon="MESH_DATA")
        if len(untagged) > UNTAGGED_SHOWN:
            col.label(text=f"... and {len(untagged) - UNTAGGED_SHOWN} more")
        box.operator(WILDSCAN_OT_select_untagged.bl_idname, icon="RESTRICT_SELECT_OFF")


CLASSES = (WILDSCAN_OT_tag, WILDSCAN_OT_select_untagged, VIEW3D_PT_wildscan_tag)
