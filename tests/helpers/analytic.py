"""An exact ray backend over planar patches, for testing the core without Blender."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wildscan.core.backend import NORMALS
from wildscan.core.hits import RayHits
from wildscan.raycast.base import broadcast_origins


@dataclass
class Patch:
    """The plane through `point` with `normal`, limited to an xy box (None: unbounded)."""

    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    class_id: int
    instance: int = 1
    xy_box: tuple[float, float, float, float] | None = None  # xmin, xmax, ymin, ymax


def slope_plane(z0: float, slope_x: float, slope_y: float, **kw) -> Patch:
    """z = z0 + slope_x·x + slope_y·y."""
    return Patch((0.0, 0.0, z0), (-slope_x, -slope_y, 1.0), **kw)


class AnalyticBackend:
    name = "analytic"
    capabilities = frozenset({NORMALS})

    def __init__(self, patches: list[Patch]):
        self.patches = patches

    def cast(self, origins, directions, max_range, normals: bool = False) -> RayHits:
        d = np.asarray(directions, dtype=np.float64)
        o = broadcast_origins(origins, len(d))
        out = RayHits.empty(len(d))
        if normals:
            out.normal = np.zeros((len(d), 3))
        for patch in self.patches:
            n = np.asarray(patch.normal, dtype=np.float64)
            denom = d @ n
            with np.errstate(divide="ignore", invalid="ignore"):
                t = ((np.asarray(patch.point) - o) @ n) / denom
            ok = np.isfinite(t) & (t > 1e-9) & (t <= max_range) & (t < out.distance)
            if patch.xy_box is not None:
                p = o + d * np.where(np.isfinite(t), t, 0.0)[:, None]
                x0, x1, y0, y1 = patch.xy_box
                ok &= (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
            out.distance[ok] = t[ok]
            out.class_id[ok] = patch.class_id
            out.instance[ok] = patch.instance
            if normals:
                out.normal[ok] = n / np.linalg.norm(n)
        return out


def weather_scene() -> AnalyticBackend:
    """Flat ground, a fence 8 m ahead and rock walls 20 to 25 m away all round."""
    terrain, fence, rock = 1, 6, 9  # class ids (core/classes.py)
    return AnalyticBackend(
        [
            Patch((0, 0, 0), (0, 0, 1), terrain),
            Patch((8, 0, 0), (-1, 0, 0), fence, instance=3, xy_box=(7, 9, -4, 4)),
            Patch((-20, 0, 0), (1, 0, 0), rock, instance=4),
            Patch((25, 0, 0), (-1, 0, 0), rock, instance=5),
            Patch((0, 22, 0), (0, -1, 0), rock, instance=6),
            Patch((0, -22, 0), (0, 1, 0), rock, instance=7),
        ]
    )
