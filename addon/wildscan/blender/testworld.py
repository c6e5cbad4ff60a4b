"""Realise the numpy test-world plan as tagged Blender objects."""

from __future__ import annotations

from ..core.world.testworld import TestWorldPlan, plan_test_world
from . import WORLD_COLLECTION
from .mesh import WORLD_ROOT_PROP, mesh_object, remove_generated, wildscan_collection


def build_test_world(seed: int, collection_name: str = WORLD_COLLECTION) -> TestWorldPlan:
    """Replace the generated objects of `collection_name` with the test world for `seed`
    (the user's own objects are left alone) and return its plan."""
    plan = plan_test_world(seed)
    remove_generated(collection_name)
    coll = wildscan_collection(collection_name)
    coll[WORLD_ROOT_PROP] = True
    for el in plan.elements:
        vertices, faces = plan.element_vertices(el), plan.prototypes[el.proto].faces
        mesh_object(el.name, vertices, faces, coll, el.wildscan_class, el.instance)
    return plan
