"""Tagged elements and the meshes they share: what a world is made of (numpy only)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..classes import class_by_name
from .shapes.primitives import Mesh, transform


@dataclass
class Prototype:
    """A mesh shared by every element that uses it (one Blender mesh, many objects)."""

    key: str
    vertices: np.ndarray
    faces: np.ndarray


@dataclass
class Element:
    """One tagged element: a prototype moved, turned (yaw, radians) and scaled."""

    name: str
    wildscan_class: str
    instance: int
    zone: str
    stage: str
    proto: str
    location: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    radius: float = 0.0  # m, top-view footprint (map, keep-outs)


class ElementSet:
    """Prototypes and the elements placed from them. A world (a dataclass) derives from it
    and declares the two fields `prototypes: dict[str, Prototype]` and
    `elements: list[Element]`."""

    def add_prototype(self, key: str, mesh: Mesh) -> str:
        self.prototypes[key] = Prototype(
            key, np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int32)
        )
        return key

    def elements_of(
        self, wildscan_class: str | None = None, zone: str | None = None, stage: str | None = None
    ) -> list[Element]:
        return [
            e
            for e in self.elements
            if (wildscan_class is None or e.wildscan_class == wildscan_class)
            and (zone is None or e.zone == zone)
            and (stage is None or e.stage == stage)
        ]

    def element_vertices(self, el: Element) -> np.ndarray:
        p = self.prototypes[el.proto]
        return transform((p.vertices, p.faces), el.location, el.yaw, el.scale)

    def triangles(self, elements=None):
        """The whole world as one indexed triangle mesh in world metres:
        (vertices (V,3), faces (T,3), class_id (T,), instance (T,), object_index (T,), names).
        Same geometry the Blender builder makes, for fast backends without Blender."""
        elements = self.elements if elements is None else elements
        verts, faces, cls, inst, obj = [], [], [], [], []
        n = 0
        for i, el in enumerate(elements):
            v = self.element_vertices(el)
            f = self.prototypes[el.proto].faces
            verts.append(v)
            faces.append(f + n)
            n += len(v)
            cls.append(np.full(len(f), class_by_name(el.wildscan_class).id, dtype=np.int16))
            inst.append(np.full(len(f), el.instance, dtype=np.int32))
            obj.append(np.full(len(f), i, dtype=np.int32))
        return (
            np.concatenate(verts),
            np.concatenate(faces).astype(np.int32),
            np.concatenate(cls),
            np.concatenate(inst),
            np.concatenate(obj),
            tuple(e.name for e in elements),
        )

    def triangle_count(self) -> int:
        return int(sum(len(self.prototypes[e.proto].faces) for e in self.elements))

    def counts(self) -> dict:
        by_class: dict[str, int] = {}
        for e in self.elements:
            by_class[e.wildscan_class] = by_class.get(e.wildscan_class, 0) + 1
        return {
            "objects": len(self.elements),
            "meshes": len({e.proto for e in self.elements}),
            "triangles": self.triangle_count(),
            "objects_by_class": dict(sorted(by_class.items())),
        }
