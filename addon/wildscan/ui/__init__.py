"""Blender UI (panel, operators, properties). Thin: it calls the same functions as the CLI.

register() and unregister() may alternate any number of times (enable, disable,
enable again): every class, property, handler, draw callback and icon they add is
removed again, and nothing is left holding a reference to an old scene.
"""

from . import draw, legend, operators, panel, properties, region, status, tag

CLASSES: tuple = (
    *properties.CLASSES,
    *operators.CLASSES,
    *region.CLASSES,
    *tag.CLASSES,
    *panel.CLASSES,
)

# (bpy.app.handlers list name, function)
_HANDLERS = (
    ("depsgraph_update_post", status.on_depsgraph_update),
    ("undo_post", draw.forget_batches),
    ("redo_post", draw.forget_batches),
    ("load_post", draw.forget_batches),
    ("undo_post", status.invalidate_on_event),
    ("redo_post", status.invalidate_on_event),
    ("load_post", status.invalidate_on_event),
)


def _remove_handlers() -> None:
    """Remove our handlers, also copies left by an earlier load of this module (a reload
    gives new function objects, so compare by module and name)."""
    import bpy

    ours = {(f.__module__, f.__qualname__) for _, f in _HANDLERS}
    for list_name, _ in _HANDLERS:
        handlers = getattr(bpy.app.handlers, list_name)
        for f in list(handlers):
            if (getattr(f, "__module__", None), getattr(f, "__qualname__", None)) in ours:
                handlers.remove(f)


def register():
    import bpy

    for cls in CLASSES:
        bpy.utils.register_class(cls)
    properties.attach()
    legend.register()
    draw.register()
    _remove_handlers()
    for list_name, function in _HANDLERS:
        getattr(bpy.app.handlers, list_name).append(bpy.app.handlers.persistent(function))
    status.invalidate()


def unregister():
    import bpy

    _remove_handlers()
    draw.unregister()
    legend.unregister()
    properties.detach()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
    status.invalidate()
