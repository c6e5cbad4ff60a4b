"""The ground cover of a world as plain data: a sward layer over the terrain (numpy only).

Real natural ground is covered (grass, herbs, ferns, shrubs), and a laser sees that cover as a
turbid layer it enters and stops in somewhere, not as a surface. So the cover is not millions of
blade triangles but a grid over the terrain: per cell the class of what grows there (low grass,
high grass, or undergrowth labelled bush; 0 bare) and the layer's height above the terrain. A
beam crossing the layer stops in it with a probability per metre (Beer-Lambert on the
layer's leaf area density, as HELIOS++ does for its vegetation voxels), applied after the cast
by core/effects/cover.py. stages/cover.py fills the grid in from the terrain and the zones.

Leaf area density (LAD, one-sided leaf area per volume, m^2/m^3) is a class's leaf area index
(LAI) spread over its height. LAI per biome type from Asner, Scurlock & Hicke (2003), "Global
synthesis of leaf area index observations", Global Ecology & Biogeography 12:191-205, table 2:
grasslands 1.7, shrublands 2.1, wetlands 6.3 (the tall grass and reeds by the lake).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..classes import BY_ID, class_by_name
from .heightfield import interpolate

BOTTOM_SLACK = 0.05  # m the layer reaches below its node-sampled terrain (the mesh's own wiggle)
CELL = 0.5  # m, the cover grid's cell: about a tussock's or a fern's spread

LOW_GRASS = class_by_name("low grass").id
HIGH_GRASS = class_by_name("high grass").id
BUSH = class_by_name("bush").id
COVER_CLASSES = (LOW_GRASS, HIGH_GRASS, BUSH)

# Leaf area index (m^2/m^2; Asner et al. 2003, above) and the layer's typical height (m).
# Heights: a grazed or mown meadow sward 0.1-0.3 m, tall grass and reeds 0.6-1.2 m, fern and
# bramble undergrowth 0.4-1 m (field descriptions of European grassland and woodland ground
# flora; the grid's own heights vary around these).
LAI = {LOW_GRASS: 1.7, HIGH_GRASS: 6.3, BUSH: 2.1}
TYPICAL_HEIGHT = {LOW_GRASS: 0.25, HIGH_GRASS: 0.8, BUSH: 0.7}
# Ross's G function: the mean projection of unit leaf area on a plane normal to the beam; 0.5
# for a spherical (random) leaf angle distribution (Ross 1981, The Radiation Regime and
# Architecture of Plant Stands; the value HELIOS++ and most canopy models use).
G_SPHERICAL = 0.5
# G LAI per class (0 for bare ground). A cell's leaf area density is its class's LAI over the
# cell's own height (LAD = LAI / h): LAI is leaf area per ground area, the figure of the
# vegetation type whatever its height, so a cell's height spreads its leaf area, it does not
# add to it (a short sward is a dense one: a 0.12 m lawn hides the soil as a meadow does).
G_LAI = np.zeros(max(BY_ID) + 1, dtype=np.float64)
for _c in COVER_CLASSES:
    G_LAI[_c] = G_SPHERICAL * LAI[_c]


def extinction(cls: np.ndarray, height: np.ndarray) -> np.ndarray:
    """Attenuation per metre of path (1/m) in cells of class `cls` and layer height `height`:
    Beer-Lambert, P(pass s) = exp(-G LAD s) with LAD = LAI / height; 0 on bare ground."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(height > 0, G_LAI[cls] / height, 0.0)


# A cover point's instance: one per class, above every element stage's block (plan.py), so a
# cover return never shares an instance with an element.
COVER_INSTANCE_BASE = 900_000
COVER_INSTANCE_END = COVER_INSTANCE_BASE + 256  # one a class id (the endless tiles' ids lie above)


def is_cover_instance(instance) -> np.ndarray:
    """Whether instance ids are the cover layer's (COVER_INSTANCE_BASE + class id)."""
    instance = np.asarray(instance)
    return (instance >= COVER_INSTANCE_BASE) & (instance < COVER_INSTANCE_END)


# A Blender world keeps its grid as custom properties of its root collection (to_props).
PROP_PREFIX = "wildscan_"
SHAPE_PROP = "wildscan_cover_shape"


@dataclass
class CoverGrid:
    """A cover layer over a terrain. Cell (j, i) spans x0 + i*cell .. x0 + (i+1)*cell (and the
    same in y); `class_id` (ny, nx) uint8 is what grows there (0 none), `height` (ny, nx)
    float32 the layer's top above the terrain. The terrain is the world's grid mesh (xs, ys,
    z), the very surface the layer stands on."""

    x0: float
    y0: float
    cell: float
    class_id: np.ndarray
    height: np.ndarray
    terrain_xs: np.ndarray
    terrain_ys: np.ndarray
    terrain_z: np.ndarray

    def __post_init__(self):
        self.class_id = np.ascontiguousarray(self.class_id, dtype=np.uint8)
        self.height = np.ascontiguousarray(self.height, dtype=np.float32)
        self.height[self.class_id == 0] = 0.0
        self.terrain_xs = np.asarray(self.terrain_xs, dtype=np.float64)
        self.terrain_ys = np.asarray(self.terrain_ys, dtype=np.float64)
        self.terrain_z = np.asarray(self.terrain_z, dtype=np.float64)
        self._nodes: np.ndarray | None = None
        self._top: np.ndarray | None = None
        self._table: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return self.class_id.shape

    def cells(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """(flat cell index, inside the grid) of points."""
        ny, nx = self.shape
        i = np.floor((np.asarray(x) - self.x0) / self.cell).astype(np.int64)
        j = np.floor((np.asarray(y) - self.y0) / self.cell).astype(np.int64)
        inside = (i.astype(np.uint64) < nx) & (j.astype(np.uint64) < ny)  # negatives wrap to huge
        if np.all(inside):
            return j * nx + i, inside
        return np.clip(j, 0, ny - 1) * nx + np.clip(i, 0, nx - 1), inside

    def ground(self, x, y) -> np.ndarray:
        """The terrain's height under points (the surface the layer stands on)."""
        return interpolate(self.terrain_xs, self.terrain_ys, self.terrain_z, x, y)

    def at(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """(class id, layer height) at points (0, 0 outside the grid)."""
        flat, inside = self.cells(x, y)
        cls = np.where(inside, self.class_id.reshape(-1)[flat], 0)
        height = np.where(inside, self.height.reshape(-1)[flat], 0.0)
        return cls, height

    def surface(self, points: np.ndarray):
        """At points (N, 3): (class, layer height, terrain height, its slope d/dx, d/dy)
        (surface_at)."""
        p = np.asarray(points, dtype=np.float64)
        return self.surface_at(np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]))

    def surface_at(self, x: np.ndarray, y: np.ndarray, slopes: bool = True):
        """At points (x, y): (class, layer height, terrain height, its slope d/dx, d/dy; the
        slopes None unless `slopes`). The terrain here is the world's sampled at the grid's
        nodes, bilinear in between (the world's mesh follows it within centimetres); outside
        the grid the class is 0."""
        ny, nx = self.shape
        fx = (x - self.x0) / self.cell
        fy = (y - self.y0) / self.cell
        i = np.floor(fx).astype(np.int64)
        j = np.floor(fy).astype(np.int64)
        out = (i.astype(np.uint64) >= nx) | (j.astype(np.uint64) >= ny)  # negatives wrap to huge
        if out.any():  # (inside the grid fx - i lies in [0, 1) already: no clipping to do)
            i, j = np.clip(i, 0, nx - 1), np.clip(j, 0, ny - 1)
            tx, ty = np.clip(fx - i, 0.0, 1.0), np.clip(fy - j, 0.0, 1.0)
        else:
            tx, ty = fx - i, fy - j
        # one gather a point: its cell's record (48 contiguous bytes)
        z00, z10, z01, z11, height, cls = self._cell_table().take(j * nx + i, axis=0).T
        sx, sy = 1 - tx, 1 - ty
        ground = (z00 * sx + z10 * tx) * sy + (z01 * sx + z11 * tx) * ty
        gx = gy = None
        if slopes:
            gx = ((z10 - z00) * sy + (z11 - z01) * ty) / self.cell
            gy = ((z01 - z00) * sx + (z11 - z10) * tx) / self.cell
        if out.any():
            cls, height = np.where(out, 0, cls), np.where(out, 0.0, height)
        return cls.astype(np.int16), height, ground, gx, gy

    def surface_near(self, x: np.ndarray, y: np.ndarray, z: np.ndarray):
        """The points (x, y, z) that may lie in the layer (may_be_inside_at), as indices, and
        surface_at (with slopes) at those: one cell lookup for both, the same values."""
        ny, nx = self.shape
        fx = (x - self.x0) / self.cell
        fy = (y - self.y0) / self.cell
        i = np.floor(fx).astype(np.int64)
        j = np.floor(fy).astype(np.int64)
        inside = (i.astype(np.uint64) < nx) & (j.astype(np.uint64) < ny)  # negatives wrap to huge
        flat = j * nx + i if inside.all() else np.clip(j, 0, ny - 1) * nx + np.clip(i, 0, nx - 1)
        near = np.flatnonzero(inside & (z <= self._tops().take(flat)))
        flat = flat.take(near)
        # inside the grid fx - i lies in [0, 1): surface_at's values, exactly
        fx -= i
        fy -= j
        tx, ty = fx.take(near), fy.take(near)
        z00, z10, z01, z11, height, cls = self._cell_table().take(flat, axis=0).T
        sx, sy = 1 - tx, 1 - ty
        ground = (z00 * sx + z10 * tx) * sy + (z01 * sx + z11 * tx) * ty
        gx = ((z10 - z00) * sy + (z11 - z01) * ty) / self.cell
        gy = ((z01 - z00) * sx + (z11 - z10) * tx) / self.cell
        return near, (cls.astype(np.int16), height, ground, gx, gy)

    def _cell_table(self) -> np.ndarray:
        """(ny * nx, 6) float64, a row a cell (row-major): the terrain at its four corners
        (x0y0, x1y0, x0y1, x1y1), its layer's height and its class. Built once: surface_at()
        gathers a point's whole cell in one step (the values are the grid's own, exactly)."""
        if self._table is None:
            z = self.node_ground()
            fields = (z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:], self.height, self.class_id)
            self._table = np.stack([np.asarray(f, dtype=np.float64).reshape(-1) for f in fields], axis=1)
        return self._table

    def class_inside(self, points: np.ndarray) -> np.ndarray:
        """int16 (N,): the cover class at points (N, 3) inside the layer, 0 elsewhere. The
        layer is, over each covered cell, from BOTTOM_SLACK below the terrain (surface())
        up to the cell's height above it."""
        cls, height, ground, _, _ = self.surface(points)
        above = np.asarray(points, dtype=np.float64)[:, 2] - ground
        return np.where((above >= -BOTTOM_SLACK) & (above <= height), cls, 0).astype(np.int16)

    def may_be_inside(self, points: np.ndarray) -> np.ndarray:
        """A cheap superset of class_inside(points) > 0: over a covered cell and not above its
        highest node plus its height (one gather a point; for skipping the exact test)."""
        p = np.asarray(points, dtype=np.float64)
        return self.may_be_inside_at(p[:, 0], p[:, 1], p[:, 2])

    def may_be_inside_at(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """may_be_inside at points (x, y, z)."""
        flat, inside = self.cells(x, y)
        return inside & (z <= self._tops().take(flat))

    def top_within(self, x: float, y: float, reach: float) -> float:
        """The highest any cell's layer reaches within `reach` of (x, y) in x and y (a square
        around it; -inf where no covered cell is): no point higher lies in the layer there."""
        ny, nx = self.shape
        i0, i1 = (int(np.floor((v - self.x0) / self.cell)) for v in (x - reach, x + reach))
        j0, j1 = (int(np.floor((v - self.y0) / self.cell)) for v in (y - reach, y + reach))
        window = self._tops().reshape(ny, nx)[max(j0, 0) : max(j1 + 1, 0), max(i0, 0) : max(i1 + 1, 0)]
        return float(window.max()) if window.size else -np.inf

    def _tops(self) -> np.ndarray:
        """(ny * nx,) each cell's highest corner plus its layer's height, -inf where bare."""
        if self._top is None:
            g = self.node_ground()
            corners = np.maximum(np.maximum(g[:-1, :-1], g[1:, :-1]), np.maximum(g[:-1, 1:], g[1:, 1:]))
            self._top = np.where(self.class_id > 0, corners + self.height, -np.inf).reshape(-1)
        return self._top

    def use_node_ground(self, nodes: np.ndarray) -> None:
        """Take the terrain at the nodes as already computed (by the stage that made the grid)."""
        assert nodes.shape == (self.shape[0] + 1, self.shape[1] + 1)
        self._nodes = np.asarray(nodes, dtype=np.float64)

    def node_ground(self) -> np.ndarray:
        """(ny+1, nx+1) the terrain's height at the grid's nodes (computed once)."""
        if self._nodes is None:
            ny, nx = self.shape
            xs = self.x0 + np.arange(nx + 1) * self.cell
            ys = self.y0 + np.arange(ny + 1) * self.cell
            self._nodes = self.ground(*np.meshgrid(xs, ys))
        return self._nodes

    def inside_layer(self, points: np.ndarray) -> np.ndarray:
        """Whether points (N, 3) lie inside the layer (class_inside)."""
        return self.class_inside(points) > 0

    def shares(self) -> dict[str, float]:
        """The share of the grid's cells under each cover class (and bare)."""
        total = self.class_id.size
        out = {"bare": float((self.class_id == 0).sum()) / total}
        for c in COVER_CLASSES:
            out[BY_ID[c].name] = float((self.class_id == c).sum()) / total
        return out

    def nbytes(self) -> int:
        """The bytes of the grid as a scan uses it: its arrays and the lookup tables a scan
        builds (the terrain at the nodes, the cells' records and tops), built or not yet."""
        ny, nx = self.shape
        tables = 8 * ((ny + 1) * (nx + 1) + ny * nx * 7)
        return int(self.class_id.nbytes + self.height.nbytes + self.terrain_z.nbytes + tables)

    # -- as plain lists and arrays (a .blend's custom properties, a geometry file) ----------

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {
            "cover_origin": np.array([self.x0, self.y0, self.cell], dtype=np.float64),
            "cover_class": self.class_id,
            "cover_height": self.height,
            "cover_terrain_xs": self.terrain_xs,
            "cover_terrain_ys": self.terrain_ys,
            "cover_terrain_z": self.terrain_z,
        }

    def to_props(self) -> dict[str, list]:
        """As custom properties of a Blender world's root collection (plain lists)."""
        props: dict[str, list] = {SHAPE_PROP: list(self.shape)}
        for name, values in self.to_arrays().items():
            values = np.asarray(values).reshape(-1)
            props[PROP_PREFIX + name] = values.astype(
                np.int32 if values.dtype.kind in "iu" else np.float64
            ).tolist()
        return props

    @staticmethod
    def from_props(props) -> CoverGrid | None:
        """The grid kept in custom properties (to_props; `props` anything with .get and []),
        None when they hold none."""
        if props.get(SHAPE_PROP) is None:
            return None
        names = ("origin", "class", "height", "terrain_xs", "terrain_ys", "terrain_z")
        arrays = {f"cover_{n}": np.array(props[f"{PROP_PREFIX}cover_{n}"]) for n in names}
        return CoverGrid.from_arrays(arrays, tuple(int(v) for v in props[SHAPE_PROP]))

    @staticmethod
    def from_arrays(arrays, shape: tuple[int, int] | None = None) -> CoverGrid:
        x0, y0, cell = (float(v) for v in np.asarray(arrays["cover_origin"]).reshape(3))
        xs = np.asarray(arrays["cover_terrain_xs"], dtype=np.float64).reshape(-1)
        ys = np.asarray(arrays["cover_terrain_ys"], dtype=np.float64).reshape(-1)
        cls = np.asarray(arrays["cover_class"])
        height = np.asarray(arrays["cover_height"])
        if shape is not None:
            cls, height = cls.reshape(shape), height.reshape(shape)
        z = np.asarray(arrays["cover_terrain_z"], dtype=np.float64).reshape(len(ys), len(xs))
        return CoverGrid(x0, y0, cell, cls, height, xs, ys, z)
