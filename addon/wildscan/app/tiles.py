"""The endless world's geometry, tile by tile, through the world cache (numpy only, no bpy).

The endless layout (core/world/endless/) is a pure function of (seed, biome, detail,
vegetation, tile, level): a tile's triangles never depend on which tiles were built before
or in what order. So a tile is the unit kept: one world-cache entry per tile and level
(`tile-<key>.npz`, keyed by those inputs and the code, app/cache/key.py), and in memory a
least-recently-used set of tiles bounded in bytes (`TileMemory`, app/tile_memory.py), so a process that scans
poses kilometres apart holds only the tiles of its last scans.

Any set of tiles is joined the one way, in sorted tile order (`join`): their triangles one
after the other, object indices moved past the previous tiles' objects, the ground cover
merged. Two regions that share tiles therefore give the shared tiles' triangles bit for
bit, whichever was built first or came from the cache.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..core.world.region import Region
from ..raycast.geometry import SceneGeometry, concatenate, local_origin
from .cache.key import entry_key
from .cache.store import DiskCache
from .tile_memory import TILE_WORK, TileCounts, TileMemory

TILE = "tile"  # the cache entry's kind
GEOMETRY_ARRAYS = ("vertices", "faces", "class_id", "instance", "object_index", "reflectivity")


def endless():
    """The endless layout's module (imported when first needed: it is the world's half)."""
    from ..core.world import endless as module

    return module


@dataclass(frozen=True)
class TiledWorld:
    """What a tile is a function of, besides its coordinates and level."""

    seed: int
    biome: str
    detail: str
    vegetation: str

    def inputs(self, tile, level) -> dict:
        return {
            "layout": "endless",
            "seed": int(self.seed),
            "biome": self.biome,
            "detail": self.detail,
            "vegetation": self.vegetation,
            "tile": [int(tile[0]), int(tile[1])],
            "level": int(level),
        }


@dataclass
class TilePart:
    """One tile at one level: its triangles (object indices into its own names) and cover,
    and each object's xy bounding box (what a scan's crop tests first: object_bounds)."""

    geometry: SceneGeometry
    cover: object  # CoverGrid or None
    object_lo: np.ndarray | None = None  # (objects, 2) float64; None: computed when first asked
    object_hi: np.ndarray | None = None

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        if self.object_lo is None:
            self.object_lo, self.object_hi = object_bounds(self.geometry)
        return self.object_lo, self.object_hi

    def nbytes(self) -> int:
        g = self.geometry
        arrays = (g.vertices, g.faces, g.class_id, g.instance, g.object_index, g.reflectivity)
        size = sum(a.nbytes for a in arrays) + 64 * len(g.object_names) + 32 * len(g.object_names)
        return size + (self.cover.nbytes() if self.cover is not None else 0)


def object_bounds(geometry: SceneGeometry) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), (objects, 2): the xy bounding box of each object's triangles (an object with
    none: an empty box at the origin, never asked for). A triangle's box lies inside its
    object's, so an object whose box is farther than a crop's radius has no triangle in it."""
    n = len(geometry.object_names)
    lo, hi = np.zeros((n, 2)), np.zeros((n, 2))
    if not geometry.triangle_count:
        return lo, hi
    xy, f = geometry.vertices[:, :2], geometry.faces
    a, b, c = xy[f[:, 0]], xy[f[:, 1]], xy[f[:, 2]]
    t_lo, t_hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
    order = np.argsort(geometry.object_index, kind="stable")  # plan_geometry's are sorted already
    objects = geometry.object_index[order]
    starts = np.flatnonzero(np.r_[True, objects[1:] != objects[:-1]])
    lo[objects[starts]] = np.minimum.reduceat(t_lo[order], starts, axis=0)
    hi[objects[starts]] = np.maximum.reduceat(t_hi[order], starts, axis=0)
    return lo, hi


def objects_near(lo: np.ndarray, hi: np.ndarray, centre, radius: float) -> np.ndarray:
    """Whether each box comes within `radius` of `centre` in xy (triangles_near_xy's test)."""
    c = np.asarray(centre, dtype=np.float64)[:2]
    gap = np.clip(c, lo, hi) - c
    return gap[:, 0] * gap[:, 0] + gap[:, 1] * gap[:, 1] <= radius * radius


def tile_part(
    world: TiledWorld,
    tile,
    level: int,
    cache: DiskCache | None = None,
    memory: TileMemory | None = None,
    counts: TileCounts | None = None,
) -> TilePart:
    """The tile at `level`: from memory, else the world cache, else built (and kept in both)."""
    key = entry_key(TILE, world.inputs(tile, level))
    counts = TileCounts() if counts is None else counts
    part = memory.get(key) if memory is not None else None
    if part is not None:
        counts.memory += 1
        return part
    t0 = time.perf_counter()
    entry = cache.get(TILE, key) if cache is not None else None
    if entry is not None:
        part = part_from_entry(entry.meta, entry.arrays)
        counts.cache += 1
        TILE_WORK.read += 1
        TILE_WORK.read_seconds += time.perf_counter() - t0
    else:
        ready_library(world, cache)
        part = build_tile(world, tile, level)
        counts.built += 1
        if cache is not None:
            cache.put(TILE, key, *part_to_entry(part))
        TILE_WORK.built += 1
        TILE_WORK.build_seconds += time.perf_counter() - t0  # the cache's miss included
    if memory is not None:
        memory.put(key, part)
    return part


LIBRARY = "library"  # the cache entry of the meshes every tile of a world shares
_LIBRARIES_READY: set[tuple] = set()


def ready_library(world: TiledWorld, cache: DiskCache | None) -> None:
    """The shared meshes of the world's tiles (core/world/endless/library.py, about a second of
    porous crowns to draw) in this process before its first tile is built: from the world
    cache when it holds them (a pure function of seed, detail, vegetation and the code),
    else drawn and kept there, so a fresh process's first tile does not draw them again."""
    from ..core.world.endless import library as L

    inputs = {"seed": int(world.seed), "detail": world.detail, "vegetation": world.vegetation}
    ready = tuple(inputs.values())
    if ready in _LIBRARIES_READY or cache is None:
        return
    key = entry_key(LIBRARY, inputs)
    entry = cache.get(LIBRARY, key)
    if entry is not None:
        names = entry.meta["names"]
        L.provide_library(
            world.seed,
            world.detail,
            world.vegetation,
            {n: entry.arrays[f"a{k}"] for k, n in enumerate(names)},
        )
    else:
        arrays = L.library_arrays(L.library(world.seed, world.detail, world.vegetation))
        names = sorted(arrays)
        cache.put(LIBRARY, key, {"names": names}, {f"a{k}": arrays[n] for k, n in enumerate(names)})
    _LIBRARIES_READY.add(ready)


def build_tile(world: TiledWorld, tile, level: int) -> TilePart:
    """Plan one tile (core/world/endless) and make its triangles as Blender would hold them."""
    from ..raycast.from_plan import plan_geometry

    tile = (int(tile[0]), int(tile[1]))
    plan = endless().plan_region(
        world.seed, world.biome, world.detail, world.vegetation, [tile], {tile: int(level)}
    )
    geometry = plan_geometry(plan)
    part = TilePart(geometry, geometry.cover)
    part.bounds()
    return part


def part_to_entry(part: TilePart) -> tuple[dict, dict[str, np.ndarray]]:
    g = part.geometry
    arrays = {name: getattr(g, name) for name in GEOMETRY_ARRAYS}
    arrays["object_lo"], arrays["object_hi"] = part.bounds()
    if part.cover is not None:
        arrays.update(part.cover.to_arrays())
    meta = {
        "object_names": list(g.object_names),
        "cover": part.cover is not None,
        "offset": g.offset.tolist(),
    }
    return meta, arrays


def part_from_entry(meta: dict, arrays: dict[str, np.ndarray]) -> TilePart:
    from ..core.world.cover import CoverGrid

    geometry = SceneGeometry(
        **{name: arrays[name] for name in GEOMETRY_ARRAYS},
        object_names=tuple(meta["object_names"]),
        offset=np.array(meta["offset"], dtype=np.float64),
    )
    cover = CoverGrid.from_arrays(arrays) if meta.get("cover") else None
    geometry.cover = cover
    return TilePart(geometry, cover, arrays["object_lo"], arrays["object_hi"])


def join(parts: list[TilePart], centre=None, radius: float | None = None, keep=None) -> SceneGeometry:
    """The tiles as one SceneGeometry (in the order given: callers sort by tile), object
    indices moved past the previous tiles' objects, covers merged; `offset` at `centre`
    (x, y) when given (a scan's pose), else the middle of the triangles. With `radius`, each
    tile keeps only the triangles SceneGeometry.cropped(centre, radius) keeps, before the
    join: the triangles of the objects whose box comes that near (object_bounds), a set
    that holds every triangle the crop keeps, in the same order, so the scan's own crop of
    the join keeps the same triangles in the same order as a crop of the whole; the rest is
    never copied. `keep(vertices, faces)`: a boolean mask of the given triangles of a part
    (those that crop leaves) to keep, the others left out of the join too (app/scan.py: the
    ones no beam of a scan can reach)."""
    names: list[str] = []
    moved = []
    for part in parts:
        g = cut(part, centre, radius, keep).geometry
        shifted = SceneGeometry(
            g.vertices,
            g.faces,
            g.class_id,
            g.instance,
            g.object_index + len(names),
            (),
            g.offset,
            g.reflectivity,
        )
        names.extend(g.object_names)
        moved.append(shifted)
    geometry = concatenate(moved, object_names=tuple(names))
    if centre is not None:
        geometry.offset = local_origin(
            geometry.vertices, geometry.faces, np.asarray(centre, dtype=np.float64)
        )
    covers = [p.cover for p in parts if p.cover is not None]
    geometry.cover = merge_covers(covers) if covers else None
    return geometry


def cut(part: TilePart, centre=None, radius: float | None = None, keep=None) -> TilePart:
    """One tile's part as `join` takes it into the whole (its docstring: the objects near
    `centre`, then `keep`'s triangles); the part itself when nothing is left out."""
    g = part.geometry
    chosen = None  # indices of the triangles kept, None: all
    if radius is not None:
        near = objects_near(*part.bounds(), centre, float(radius))[g.object_index]
        chosen = None if near.all() else np.flatnonzero(near)
    if keep is not None:
        faces = g.faces if chosen is None else g.faces[chosen]
        mask = keep(g.vertices, faces)
        if not mask.all():
            chosen = np.flatnonzero(mask) if chosen is None else chosen[mask]
    return part if chosen is None else TilePart(g.subset(chosen), part.cover)


def merge_covers(covers: list):
    """One CoverGrid of several tiles' grids (each over its own tile, the same cell and the
    same terrain lattice spacing; core/world/endless region.py builds a region's the same
    way): their cells and terrain nodes laid side by side over the tiles' bounding box. A
    place no given tile covers has no cover (class 0) and the lowest terrain given (so no
    layer top there rises above a real one)."""
    from ..core.world.cover import CoverGrid

    if len(covers) == 1:
        return covers[0]
    first = covers[0]
    cell = first.cell
    step = float(first.terrain_xs[1] - first.terrain_xs[0])
    x0 = min(c.x0 for c in covers)
    y0 = min(c.y0 for c in covers)
    x1 = max(c.x0 + c.shape[1] * cell for c in covers)
    y1 = max(c.y0 + c.shape[0] * cell for c in covers)
    nx, ny = int(round((x1 - x0) / cell)), int(round((y1 - y0) / cell))
    cls = np.zeros((ny, nx), dtype=np.uint8)
    height = np.zeros((ny, nx), dtype=np.float32)
    xs = x0 + step * np.arange(int(round((x1 - x0) / step)) + 1)
    ys = y0 + step * np.arange(int(round((y1 - y0) / step)) + 1)
    z = np.full((len(ys), len(xs)), min(float(c.terrain_z.min()) for c in covers))
    for c in covers:
        a, b = int(round((c.x0 - x0) / cell)), int(round((c.y0 - y0) / cell))
        cls[b : b + c.shape[0], a : a + c.shape[1]] = c.class_id
        height[b : b + c.shape[0], a : a + c.shape[1]] = c.height
        p, q = int(round((c.terrain_xs[0] - x0) / step)), int(round((c.terrain_ys[0] - y0) / step))
        z[q : q + len(c.terrain_ys), p : p + len(c.terrain_xs)] = c.terrain_z
        xs[p : p + len(c.terrain_xs)] = c.terrain_xs  # the tiles' own node coordinates, bit for bit
        ys[q : q + len(c.terrain_ys)] = c.terrain_ys
    return CoverGrid(x0, y0, cell, cls, height, xs, ys, z)


def tiles_geometry(
    world: TiledWorld,
    levels: dict,
    cache: DiskCache | None = None,
    memory: TileMemory | None = None,
    centre=None,
    progress=None,
    radius: float | None = None,
    region: Region | None = None,
) -> tuple[SceneGeometry, TileCounts]:
    """The geometry of the tiles `levels` names (tile -> level), joined in sorted tile
    order, and where they came from: cropped to `radius` around `centre` when given (join),
    or to the triangles meeting `region` (crop_to_region, tile by tile: only the kept
    triangles are ever held together). `progress(done, total)` after each tile."""
    t0 = time.perf_counter()

    def cropped(part: TilePart) -> TilePart:
        return TilePart(crop_to_region(part.geometry, region), part.cover)

    parts, counts = tile_parts(world, levels, cache, memory, progress, cropped if region else None)
    geometry = join(parts, centre, radius)
    counts.seconds = time.perf_counter() - t0
    return geometry, counts


def tile_parts(
    world: TiledWorld,
    levels: dict,
    cache: DiskCache | None = None,
    memory: TileMemory | None = None,
    progress=None,
    each=None,
) -> tuple[list[TilePart], TileCounts]:
    """The parts of the tiles `levels` names (tile -> level), in sorted tile order (join's),
    and where they came from; `each(part)`, when given, makes each tile's part before the
    next is made (a region's crop: only the kept triangles are held together).
    `progress(done, total)` after each tile."""
    counts = TileCounts()
    t0 = time.perf_counter()
    parts = []
    tiles = sorted(levels)
    for k, tile in enumerate(tiles):
        part = tile_part(world, tile, levels[tile], cache, memory, counts)
        parts.append(part if each is None else each(part))
        if progress is not None:
            progress(k + 1, len(tiles))
    counts.seconds = time.perf_counter() - t0
    return parts, counts


def full_detail(tiles) -> dict:
    """Every tile at level 0, full detail (a region built for a file, poses or `--lod off`)."""
    return {tuple(int(v) for v in tile): 0 for tile in tiles}


# How far an element's triangles may reach past its own tile (a crown over the edge): the
# tiles this near a region are built too, so a region holds every triangle that meets it
# whichever tile owns it. Measured: at most 3.2 m over five tiles of seed 1 (object_bounds);
# endless's tile_levels builds 5 m past a sensor's reach for the same reason (RANGE_MARGIN).
ELEMENT_OVERHANG_M = 5.0


def region_levels(region: Region, m: float = ELEMENT_OVERHANG_M) -> dict:
    """The tiles whose elements can meet a region (within `m` of it), all at full detail."""
    return full_detail(
        endless().tiles_in_region(region.xmin - m, region.ymin - m, region.xmax + m, region.ymax + m)
    )


def scan_levels(sensor, x: float, y: float, reach: float, lod: bool, detail: str = "default") -> dict:
    """The tiles a scan from (x, y) can reach (`reach`: app/scan.py crop_radius, the sensor's
    range and what a scan casts past it) and the level of each (core/world/endless
    tile_levels, from the device's beam spacing; all full detail when `lod` is off)."""
    levels = endless().tile_levels(sensor, x, y, lod, detail, reach=reach)
    return {(int(t[0]), int(t[1])): int(level) for t, level in levels.items()}


def crop_to_region(geometry: SceneGeometry, region: Region) -> SceneGeometry:
    """The triangles whose xy bounding box meets the region (a whole triangle or none: cut
    triangles would differ between two regions that share them)."""
    xy, f = geometry.vertices[:, :2], geometry.faces
    a, b, c = xy[f[:, 0]], xy[f[:, 1]], xy[f[:, 2]]
    low, high = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
    keep = (
        (high[:, 0] >= region.xmin)
        & (low[:, 0] <= region.xmax)
        & (high[:, 1] >= region.ymin)
        & (low[:, 1] <= region.ymax)
    )
    part = geometry.subset(keep)
    part.cover = geometry.cover
    return part


# m: every triangle this near the pose (in xy) is kept, so the rays that place the robot (the
# ground probe, the lasers at its arms' ends within 0.5 m, the 1 m enclosing test) meet the
# same triangles in the culled geometry as in the whole, and the scan stands where it was placed
PLACEMENT_RADIUS_M = 5.0


def placement_caster(parts, centre, backend: str = "embree"):
    """A ray caster over the triangles of the tiles `parts` (app/tiles.py TilePart, sorted by
    tile) within PLACEMENT_RADIUS_M of `centre` (x, y), or (x, y, z) to set its local origin's
    height too (app/poses.py placement_centre): every triangle a placement there can meet, so
    a pose placed on it stands where it stands on all of the tiles (the pose search,
    app/poses.py, and app/scan.py beam_reach place on it; a scan places itself on its whole
    crop)."""
    from ..raycast.select import make_backend

    near = join(parts, centre, PLACEMENT_RADIUS_M)
    return make_backend(backend, center=centre, radius=PLACEMENT_RADIUS_M, geometry=near, notify=None)
