"""Stage "cover": the sward layer over the ground (core/world/cover.py CoverGrid), driven by the
terrain and each zone's character; none in the paper biome.

Per 0.5 m cell, in this order (the first that holds decides):

  bare          where an element may not stand (the water, the park's fence line), the cave
                itself (its pit, ramp and roof), on slopes steeper than 38 deg, under rocks and
                deadwood; the trail's wheel tracks
  two-track     the rest of the trail's tread: low grass between the wheel tracks (the median)
                and beside them (_two_track)
  tall grass    where it is wet: the lake's shore (up to WET_ABOVE_LAKE above the water) and
                basins (ground BASIN_DEPTH below its surroundings); reeds by the lake
  undergrowth   under a tree's crown (shade), the biome's share of it (ferns, bramble: bush);
                the rest of the forest's floor is leaf litter (bare) or shade grass, the rest
                under a tree outside the forest shade grass (a lone tree's litter does not
                cover the meadow under it)
  open ground   the biome's shares of shrubs (bush) and tall grass, the rest meadow (low grass);
                the park's lawn is short mown grass

Shares are taken as patches of a smooth random field (drawn from this stage's generator), so
grass, shrubs and tall grass come in clumps as they grow, not cell by cell.
"""

from __future__ import annotations

import numpy as np

from .. import cover as C
from ..biomes import biome_of
from ..geometry2d import polyline_frame
from ..plan import EXTENT, HALF, Clearance, WorldPlan

STAGE = "cover"

BARE_SLOPE_TAN = 0.7812856265  # tan 38 deg: steeper ground holds no sward (scree, cut banks)
WET_ABOVE_LAKE = 0.9  # m above the water level: the shore's wet band
BASIN_DEPTH = 0.5  # m below the mean ground within BASIN_RADIUS: a wet hollow
BASIN_RADIUS = 8.0  # m
LAWN_HEIGHT = 0.12  # m: a park lawn between mowings
SHADE_GRASS = 0.35  # share of the shaded floor that is not undergrowth under shade grass (rest: litter)
ZONE_MARGIN = 2.0  # m around a zone's cell where its shape's keep-out is asked
PATCH = 6.0  # m: the size of a patch of the random fields
# A two-track's wheel tracks lie a vehicle's track width apart, centre to centre: wheel strips
# "about 4 feet 8 inches on centres" (1.42 m), 18 in (0.46 m) wide (chestofbooks.com,
# Construction-House, "Concrete Driveway": a double runway for the wheels), ribbons "spaced
# approximately five feet on center to align with the standard wheel track width" (1.52 m),
# at least 24 in wide (engineerfix.com, "How to build a classic brick ribbon driveway").
WHEEL_GAUGE = 1.5  # m between the two wheel tracks' centre lines


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    biome = biome_of(plan.biome)
    if not biome.cover:
        return
    n = int(round(2 * HALF / C.CELL))
    centres = EXTENT[0] + (np.arange(n) + 0.5) * C.CELL
    x, y = np.meshgrid(centres, centres)
    corners = EXTENT[0] + np.arange(n + 1) * C.CELL
    nodes = plan.ground(*np.meshgrid(corners, corners))  # the layer's terrain (CoverGrid.surface)
    ground = 0.25 * (nodes[:-1, :-1] + nodes[1:, :-1] + nodes[:-1, 1:] + nodes[1:, 1:])
    patch, tall, height_noise = (_smooth_field(rng, n) for _ in range(3))

    tread = _tread(plan, n)
    bare_ground = _bare(plan, x, y, ground)
    bare = bare_ground | tread
    wet = _wet(plan, x, y, ground) & ~bare
    shade = _shade(plan, x, y) & ~bare & ~wet
    open_ = ~bare & ~wet & ~shade

    cls = np.zeros((n, n), dtype=np.uint8)
    cls[wet] = C.HIGH_GRASS
    under = shade & (patch < biome.undergrowth)
    cls[under] = C.BUSH
    shade_grass = shade & ~under & ((tall < SHADE_GRASS) | ~_in_cell(plan, "forest", x, y))
    cls[shade_grass] = C.LOW_GRASS
    shrub = open_ & (patch > 1.0 - biome.open_shrub)
    cls[shrub] = C.BUSH
    tall_open = open_ & ~shrub & (tall > 1.0 - biome.tall_grass)
    cls[tall_open] = C.HIGH_GRASS
    cls[open_ & ~shrub & ~tall_open] = C.LOW_GRASS
    cls[tread & ~bare_ground & ~_two_track(plan, x, y, tread)] = C.LOW_GRASS  # median and edges

    typical = np.zeros(max(C.COVER_CLASSES) + 1)
    for c in C.COVER_CLASSES:
        typical[c] = C.TYPICAL_HEIGHT[c]
    height = typical[cls] * biome.grass_height * (0.6 + 0.8 * height_noise)
    lawn = plan.layout.park.on_lawn(x, y) & (cls == C.LOW_GRASS)
    height[lawn] = LAWN_HEIGHT
    grid = plan.grid
    plan.cover = C.CoverGrid(EXTENT[0], EXTENT[2], C.CELL, cls, height, grid.xs, grid.ys, grid.z)
    plan.cover.use_node_ground(nodes)


def _tread(plan: WorldPlan, n: int) -> np.ndarray:
    """The cells of the trail's tread (its keep-out's distance is costly)."""
    tread = np.zeros((n, n), dtype=bool)
    trail = plan.layout.trail
    for px, py in trail.path:
        _stamp(tread, px, py, trail.width / 2)
    return tread


def _two_track(plan: WorldPlan, x, y, tread) -> np.ndarray:
    """The wheel tracks among the tread's cells (bool, the grid's shape). A track is the line
    WHEEL_GAUGE / 2 beside the trail's centre line, drawn as a digital line: a cell is on it
    when its centre lies within half a cell of it measured along the grid axis that crosses
    the trail's main direction, so each row (or column) along the trail has one track cell
    a side. Its width is then 0.5 m along an axis, 0.35 m on a diagonal, 0.45 m on average
    over directions: a wheel strip's (WHEEL_GAUGE's sources: 0.46-0.61 m). (A test of the
    0.5 m cells' centres against a 0.45 m band would lose the track wherever the band falls
    between two rows of centres.) The rest of the tread, the median between the tracks and
    the edges beside them, grows grass."""
    flat = np.flatnonzero(tread)
    pts = np.column_stack([x.reshape(-1)[flat], y.reshape(-1)[flat]])
    offset, tangent = polyline_frame(plan.layout.trail.path, pts)
    half = 0.5 * C.CELL * np.maximum(np.abs(tangent[:, 0]), np.abs(tangent[:, 1]))
    tracks = np.zeros(tread.shape, dtype=bool)
    tracks.reshape(-1)[flat] = np.abs(np.abs(offset) - WHEEL_GAUGE / 2) <= half
    return tracks


def _bare(plan: WorldPlan, x, y, ground) -> np.ndarray:
    need = Clearance(0.0, water_margin=0.05, park_interior=True)
    bare = np.zeros(x.shape, dtype=bool)
    trail = plan.layout.trail
    for zone, shape in plan.layout.zone_shapes().items():  # each shape lies in its zone's cell
        if shape is trail:
            continue
        x0, x1, y0, y1 = plan.layout.cells[zone]
        near = (
            (x > x0 - ZONE_MARGIN) & (x < x1 + ZONE_MARGIN) & (y > y0 - ZONE_MARGIN) & (y < y1 + ZONE_MARGIN)
        )
        bare_here = getattr(shape, "bare", None)  # the zone's own bare ground, else where elements keep out
        bare[near] |= (
            bare_here(x[near], y[near]) if bare_here else shape.keep_out(plan, x[near], y[near], need)
        )
    gy, gx = np.gradient(ground, C.CELL)
    bare |= gx * gx + gy * gy > BARE_SLOPE_TAN * BARE_SLOPE_TAN  # products only: the same bits everywhere
    for el in plan.elements:  # (the cave's rock faces and roof lie in the cave, bare already)
        if el.stage in ("rocks", "deadwood"):
            _stamp(bare, el.location[0], el.location[1], el.radius * 0.8)
    return bare


def _wet(plan: WorldPlan, x, y, ground) -> np.ndarray:
    x0, x1, y0, y1 = plan.layout.cells["lake"]
    shore = (ground < plan.water_z + WET_ABOVE_LAKE) & (x > x0) & (x < x1) & (y > y0) & (y < y1)
    k = int(round(BASIN_RADIUS / C.CELL))
    return shore | (ground < _box_mean(ground, k) - BASIN_DEPTH)


def _in_cell(plan: WorldPlan, zone: str, x, y) -> np.ndarray:
    x0, x1, y0, y1 = plan.layout.cells[zone]
    return (x > x0) & (x < x1) & (y > y0) & (y < y1)


def _shade(plan: WorldPlan, x, y) -> np.ndarray:
    shade = np.zeros(x.shape, dtype=bool)
    for el in plan.elements:
        if el.wildscan_class == "treetop":
            _stamp(shade, el.location[0], el.location[1], el.radius)
    return shade


def _stamp(mask: np.ndarray, cx: float, cy: float, radius: float) -> None:
    """Set the cells of `mask` whose centres lie within `radius` of (cx, cy)."""
    n = mask.shape[0]
    lo = np.clip(np.floor((np.array([cx, cy]) - radius - EXTENT[0]) / C.CELL).astype(int), 0, n)
    hi = np.clip(np.ceil((np.array([cx, cy]) + radius - EXTENT[0]) / C.CELL).astype(int) + 1, 0, n)
    xs = EXTENT[0] + (np.arange(lo[0], hi[0]) + 0.5) * C.CELL
    ys = EXTENT[0] + (np.arange(lo[1], hi[1]) + 0.5) * C.CELL
    inside = (xs[None, :] - cx) ** 2 + (ys[:, None] - cy) ** 2 <= radius * radius
    mask[lo[1] : hi[1], lo[0] : hi[0]] |= inside


def _box_mean(a: np.ndarray, k: int) -> np.ndarray:
    """The mean of `a` over a (2k+1)^2 box around each cell (edges: the box within the grid)."""
    padded = np.pad(a, k, mode="edge")
    c = np.cumsum(np.cumsum(np.pad(padded, ((1, 0), (1, 0))), axis=0), axis=1)
    w = 2 * k + 1
    return (c[w:, w:] - c[:-w, w:] - c[w:, :-w] + c[:-w, :-w]) / (w * w)


def _smooth_field(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, n) values in [0, 1), spatially smooth over about PATCH metres, roughly uniform: a
    coarse random grid interpolated bilinearly, then ranked (so a share s of the cells lies
    below s)."""
    coarse_n = int(np.ceil(n * C.CELL / PATCH)) + 2
    coarse = rng.random((coarse_n, coarse_n))
    t = (np.arange(n) + 0.5) * C.CELL / PATCH
    i = np.floor(t).astype(int)
    f = t - i
    rows = coarse[i] * (1 - f)[:, None] + coarse[i + 1] * f[:, None]
    field = rows[:, i] * (1 - f)[None, :] + rows[:, i + 1] * f[None, :]
    ranks = np.empty(field.size)
    ranks[np.argsort(field, axis=None, kind="stable")] = np.arange(field.size)
    return (ranks / field.size).reshape(n, n)
