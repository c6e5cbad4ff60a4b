"""One plane per visibility case, and which of them each ray backend scans (bpy; Blender
3.4 and 5.0). Imported by tests/test_scene_rules.py, and run inside Debian's Blender:
`blender -b --factory-startup -P tests/helpers/visibility_probe.py -- ADDON_DIR OUT.json`."""

from __future__ import annotations

import json
import sys

# name -> (x of its plane, whether the laser sees it: docs/scanning.md "Which objects a scan sees")
CASES = {
    "plain": (0, True),
    "hidden_object": (2, False),  # eye icon (hide_set)
    "in_hidden_collection": (4, False),  # its collection's eye icon
    "in_excluded_collection": (6, False),  # its collection unticked in the view layer
    "hide_render": (8, True),  # camera icon: the viewport still shows it
    "disabled_in_viewports": (10, False),  # monitor icon (hide_viewport)
    "zero_scale_z": (12, False),
    "zero_scale_x": (14, False),
    "tiny_scale": (16, True),
    "instanced_copy": (18, True),  # a copy of an excluded template, by a visible instancer
    "copy_of_hidden_instancer": (20, False),
}


def _plane(bpy, name, x, collection):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(
        [(x - 0.5, -0.5, 0), (x + 0.5, -0.5, 0), (x + 0.5, 0.5, 0), (x - 0.5, 0.5, 0)], [], [(0, 1, 2, 3)]
    )
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    obj["wildscan_class"] = "rock"
    return obj


def _collection(bpy, name):
    coll = bpy.data.collections.new(name)
    bpy.context.scene.collection.children.link(coll)
    return coll


def build_scene() -> None:
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    top = scene.collection
    for name in ("plain", "hide_render", "hidden_object", "disabled_in_viewports"):
        _plane(bpy, name, CASES[name][0], top)
    bpy.data.objects["hide_render"].hide_render = True
    bpy.data.objects["disabled_in_viewports"].hide_viewport = True
    _plane(bpy, "in_hidden_collection", CASES["in_hidden_collection"][0], _collection(bpy, "hidden"))
    _plane(bpy, "in_excluded_collection", CASES["in_excluded_collection"][0], _collection(bpy, "excluded"))
    for name, scale in (
        ("zero_scale_z", (1, 1, 0)),
        ("zero_scale_x", (0, 1, 1)),
        ("tiny_scale", (1, 1, 1e-9)),
    ):
        obj = _plane(bpy, name, 0, top)
        obj.location.x = CASES[name][0]
        obj.scale = scale
    templates = _collection(bpy, "templates")
    _plane(bpy, "template", 0, templates)
    for name in ("instanced_copy", "copy_of_hidden_instancer"):
        empty = bpy.data.objects.new(name, None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = templates
        empty.location.x = CASES[name][0]
        top.objects.link(empty)
    layers = bpy.context.view_layer.layer_collection.children
    layers["hidden"].hide_viewport = True
    layers["excluded"].exclude = True
    layers["templates"].exclude = True
    bpy.context.view_layer.update()
    # hide_set is per view layer and only takes once the object is in it
    bpy.data.objects["hidden_object"].hide_set(True)
    bpy.data.objects["copy_of_hidden_instancer"].hide_set(True)
    bpy.context.view_layer.update()


def seen_by(backend: str) -> list[str]:
    """The cases a ray straight down onto each plane hits, with `backend`."""
    import numpy as np

    from wildscan.raycast.select import make_backend

    names = list(CASES)
    origins = np.array([[CASES[n][0] + 0.1, 0.1, 5.0] for n in names])
    directions = np.tile([0.0, 0.0, -1.0], (len(names), 1))
    hits = make_backend(backend, notify=None).cast(origins, directions, 10.0)
    return [n for n, d in zip(names, hits.distance) if np.isfinite(d)]


def expected() -> list[str]:
    return [n for n, (_, seen) in CASES.items() if seen]


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1 :]
    sys.path.insert(0, argv[0])
    build_scene()
    with open(argv[1], "w") as f:
        json.dump({b: seen_by(b) for b in ("blender", "bvh")}, f)
