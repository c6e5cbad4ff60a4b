"""WildScan: labeled synthetic 3D laser scans of natural worlds, built in Blender.

This package is both the library behind the `wildscan` command and the Blender
add-on (legacy `bl_info` for Blender 3.4+, `blender_manifest.toml` for 4.2+).
Importing it does not import bpy; `register()` does.
"""

# The version lives here, in bl_info, and only here: Blender's legacy add-on loader reads
# bl_info as a literal, so it stays one; __version__, pyproject.toml (dynamic version) and
# the extension's blender_manifest.toml (written by tools/build_addon.py) all derive from it.
bl_info = {
    "name": "WildScan",
    "author": "WildScan engineers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > WildScan",
    "description": "Procedural natural worlds scanned by an emulated rotating Hokuyo UTM-30LX-EW, "
    "labeled per point",
    "category": "3D View",
}

__version__ = ".".join(str(part) for part in bl_info["version"])


def register():
    from .ui import register as _register

    _register()


def unregister():
    from .ui import unregister as _unregister

    _unregister()
