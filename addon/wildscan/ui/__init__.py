"""Blender UI (panel, operators, properties). Thin: it calls the same functions as the CLI."""

CLASSES: tuple = ()


def register():
    import bpy

    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    import bpy

    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
