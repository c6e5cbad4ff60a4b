"""WildScan: labeled synthetic 3D laser scans of natural worlds, built in Blender.

This package is both the library behind the `wildscan` command and the Blender
add-on (legacy `bl_info` for Blender 3.4+, `blender_manifest.toml` for 4.2+).
Importing it does not import bpy; `register()` does.
"""

__version__ = "0.1.0"

bl_info = {
    "name": "WildScan",
    "author": "WildScan engineers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > WildScan",
    "description": "Procedural natural worlds scanned by an emulated rotating Hokuyo UTM-30LX-EW, labeled per point",
    "category": "3D View",
}


def register():
    from .ui import register as _register

    _register()


def unregister():
    from .ui import unregister as _unregister

    _unregister()
