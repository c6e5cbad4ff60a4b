"""A drive of kilometres over the endless world's trail network (`drive --seed S --trail
--distance M`), its world built piece by piece along the route.

The route (core/motion/routes.py) starts at the trail point nearest the seed's origin. The
world is never built whole: the drive is cut into pieces of whole 3D scans, about PIECE_M of
path each, and a piece sees only the tiles within the sensor's reach of its own stretch
(app/tiles.py: from the process's bounded tile memory, the world cache, or built). Tiles
behind the robot fall out of the memory as new ones come in, so a drive's memory does not
grow with its length.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...core.motion.routes import trail_route
from ...core.motion.trajectory import Path, polyline_path
from ..tile_memory import TileMemory
from ..tiles import ELEMENT_OVERHANG_M, TiledWorld, endless, join, objects_near, tile_part
from .world import crop_along

PIECE_M = 40.0  # m of path a piece of the drive's world covers (whole 3D scans)
NETWORK_MARGIN_M = 300.0  # the network is read this far past the drive's reach (one anchor cell)
PLACE_REACH_M = 2.0  # m: the placement lasers stand within 0.5 m of the path (placement.py ARM_X, ARM_Y)
START = (0.0, 0.0)  # the route starts at the trail point nearest the seed's origin
# Tiles kept between pieces: a piece of PIECE_M with a 30 m sensor touches up to 3 x 3 of
# the 50 m tiles (5-40 MB each on seed 1's route); this keeps the next piece's shared tiles
# without reading them again. Not more: the sweeps' pass reads the placements' tiles back
# from the world cache anyway (a long route's tiles never all fit), and with the next
# piece's world made while one is swept (ahead.py), 700 MB took a 2 km drive to 2.29 GB
# peak; 400 MB keeps it at 1.85 GB, under the 2 GB target.
DRIVE_TILE_BYTES = 400_000_000


@dataclass
class TrailWorld:
    """The endless world of a seed as a drive sees it, piece by piece."""

    tiled: TiledWorld
    cache: object = None  # DiskCache or None
    memory: TileMemory = field(default_factory=lambda: TileMemory(DRIVE_TILE_BYTES))
    instances: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    trail = None  # the paper island's trail: none here
    cover = None  # each piece brings its own (SceneGeometry.cover)
    geometry = None
    plan = None
    tiles_seen: set = field(default_factory=set)

    @property
    def provenance(self) -> dict:
        t = self.tiled
        return {
            "seed": t.seed,
            "detail": t.detail,
            "vegetation": t.vegetation,
            "world": None,
            "layout": "endless",
            "biome": t.biome,
        }

    def route(self, distance: float, route: str) -> Path:
        """The polyline the drive follows (its first `distance` metres, or out and back)."""
        reach = distance + NETWORK_MARGIN_M
        x, y = START
        network = endless().trail_network(
            self.tiled.seed, self.tiled.biome, x - reach, y - reach, x + reach, y + reach
        )
        points = trail_route(network, START, distance, route, self.drivable)
        return polyline_path(points, "trail", "trail")

    def drivable(self, path: np.ndarray) -> bool:
        """Whether the robot can drive the trail: the land's slope (height_at, over the
        placement lasers' span) stays under MAX_TRAIL_SLOPE_DEG along it (the measure
        the endless world's trails are laid by, anchors.steepest_grades: every one of its
        trails passes; the check stays for a network laid otherwise)."""
        from ...core.world.endless.anchors import MAX_TRAIL_GRADE, steepest_grades

        seed, biome = self.tiled.seed, self.tiled.biome

        def height(x, y) -> np.ndarray:
            return endless().height_at(seed, biome, x, y)

        return bool(steepest_grades([path], height)[0] <= MAX_TRAIL_GRADE)

    def crop(self, xy: np.ndarray, radius: float):
        """Every object a sensor anywhere on `xy` (n, 2) can reach, from the tiles within
        that reach (an element overhangs its tile by up to ELEMENT_OVERHANG_M): the objects
        whose box comes within `radius` of the stretch's bounding disc. Triangles beyond the
        reach are never hit within range, so they are not cut away one by one (the triangle
        crop of a 40 m stretch cost seconds a piece)."""
        parts, centre, near = self._parts(xy, radius)
        joined = join(parts, centre, near)
        self.instances = np.union1d(self.instances, np.unique(joined.instance))
        return joined

    def ground(self, xy: np.ndarray, reach: float):
        """The triangles the placement lasers can meet along `xy` (within PLACE_REACH_M of
        it); every instance within `reach` of it is noted for the scans' labels."""
        parts, centre, near = self._parts(xy, reach)
        for part in parts:
            keep = objects_near(*part.bounds(), centre, near)[part.geometry.object_index]
            self.instances = np.union1d(self.instances, np.unique(part.geometry.instance[keep]))
        parts, centre, near = self._parts(xy, PLACE_REACH_M)
        joined = join(parts, centre, near)
        part = crop_along(joined, xy, PLACE_REACH_M)
        part.cover = joined.cover
        return part

    def _parts(self, xy: np.ndarray, radius: float):
        """(the tiles' parts within `radius` of the stretch `xy`, in sorted tile order, the
        centre and radius of a disc holding every point within `radius` of the stretch)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        m = radius + ELEMENT_OVERHANG_M
        tiles = sorted(
            tuple(int(v) for v in t)
            for t in endless().tiles_in_region(lo[0] - m, lo[1] - m, hi[0] + m, hi[1] + m)
        )
        self.tiles_seen.update(tiles)
        parts = [tile_part(self.tiled, tile, 0, self.cache, self.memory) for tile in tiles]
        return parts, 0.5 * (lo + hi), float(np.hypot(*(hi - lo)) / 2 + radius + 1.0)


def trail_world(request, cache=None) -> TrailWorld:
    """The endless world of the request's seed (`cache`: the world cache, DiskCache or None)."""
    from ...core.world import DEFAULT_BIOME

    tiled = TiledWorld(request.seed, DEFAULT_BIOME, request.detail, request.vegetation)
    return TrailWorld(tiled, cache=cache)


def pieces(scans_2d: int, sweeps: int, step_m: float, endless_world: bool) -> list[tuple[int, int]]:
    """The drive's pieces as ranges of 2D scans [k0, k1): whole 3D scans of about PIECE_M of
    path each (`step_m`: metres a 2D scan), the last holding what is left; one piece when the
    world is built whole (a paper island, a .blend)."""
    if not endless_world:
        return [(0, scans_2d)]
    per = max(1, int(PIECE_M // max(step_m * sweeps, 1e-9))) * sweeps
    edges = list(range(0, scans_2d, per))
    if len(edges) > 1 and scans_2d - edges[-1] < sweeps:  # a scrap shorter than a 3D scan joins the last
        edges.pop()
    return list(zip(edges, edges[1:] + [scans_2d]))
