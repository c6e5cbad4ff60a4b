"""Replacing the world WildScan built before with a new one, in the current scene (bpy):
the scene surgery behind every rebuild (app/world.py build_in_scene)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from . import WORLD_COLLECTION as ROOT

T = TypeVar("T")


def replacing_generated(build: Callable[[], T]) -> T:
    """Run `build()` (which builds a world into the WildScan collection) so that it
    replaces the world WildScan built before, and a failure leaves that world exactly
    as it was.

    The previous world is found by what it is, not by its collection's name (a user
    may rename it): its root collection's marker (blender/mesh.py world_root) and every
    generated, class-tagged object in the scene, wherever the user moved it. It is set
    aside while the new one is built: its generated collections, objects and data get
    temporary names, so the new world gets the same names a first build would. On
    success the user's own objects and collections in the old root move to the new one
    and the generated rest is removed; on failure the partial new world is removed and
    the old one gets its names back.
    """
    import bpy

    from .mesh import (
        GENERATED,
        remove_generated,
        remove_objects_and_their_meshes,
        world_element_objects,
        world_root,
    )

    old = world_root()
    strays = world_element_objects()
    if old is None and not strays:
        return build()
    renamed, objects = _set_aside(old, strays, GENERATED)
    try:
        result = build()
    except BaseException:
        remove_generated(ROOT)
        for block, name in renamed:
            block.name = name
        raise
    new = bpy.data.collections.get(ROOT)
    if old is not None and new is not None and new != old:
        _adopt_user_content(old, new, GENERATED)
    remove_objects_and_their_meshes(objects)
    if old is not None:
        remove_generated(old.name)
    return result


def _set_aside(root, strays: set, generated: str) -> tuple[list, set]:
    """Give the generated collections under `root` (None: none), the generated objects in
    them and the `strays` and those objects' generated data temporary names; returns
    ((datablock, original name) pairs, the objects)."""
    collections = [] if root is None else [root, *(c for c in root.children_recursive if c.get(generated))]
    objects = {o for c in collections for o in c.objects if o.get(generated)} | set(strays)
    data = {o.data for o in objects if o.data is not None and o.data.get(generated)}
    renamed = []
    for i, block in enumerate([*collections, *objects, *data]):
        renamed.append((block, block.name))
        block.name = f".wildscan-replaced-{i}"
    return renamed, objects


def _parents_of(coll) -> list:
    import bpy

    parents = [c for c in bpy.data.collections if coll.name in c.children]
    parents += [s.collection for s in bpy.data.scenes if coll.name in s.collection.children]
    return parents


def _adopt_user_content(old, new, generated: str) -> None:
    """Give `new` the place and the user content `old` had."""
    for obj in [o for o in old.objects if not o.get(generated)]:
        if obj.name not in new.objects:
            new.objects.link(obj)
        old.objects.unlink(obj)
    for child in [c for c in old.children if not c.get(generated)]:
        if child.name not in new.children:
            new.children.link(child)
        old.children.unlink(child)
    old_parents = _parents_of(old)
    if old_parents:
        for parent in old_parents:
            if new.name not in parent.children:
                parent.children.link(new)
        for parent in _parents_of(new):
            if parent not in old_parents:
                parent.children.unlink(new)
