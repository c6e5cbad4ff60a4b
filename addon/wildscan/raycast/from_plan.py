"""The Blender-free path: a world plan straight to the triangles a scan reads (numpy only)."""

from __future__ import annotations

from .geometry import SceneGeometry, local_origin


def plan_geometry(plan) -> SceneGeometry:
    """The plan's triangles as a SceneGeometry (what extract_scene gives for the built world)."""
    v, f, c, i, o, names = plan.triangles()
    geometry = SceneGeometry(v, f, c, i, o, names)
    geometry.offset = local_origin(v, f)
    return geometry
