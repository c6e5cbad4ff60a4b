"""Stage "cave": a flat-floored pit with a ramp climbing out of it, the back of the pit
covered by a roof slab resting on the plateau around it.

Everything about the cave is here: its shape (drawn during the layout stage), the
plateau and pit it carves into the terrain and which of the terrain's triangles are its
rock faces, where elements and poses keep out of it, the scan sites inside, at the
entrance and on the rim, the roof element, and its description in world.json.

What is rock and what is ground: in a biome with ground cover the roof and the pit's steep
walls are `rock`, not `terrain`: a robot drives on neither, and a network trained on
"terrain" for traversable ground must not learn a roof over its head or a wall as ground
(the floor and the ramp stay terrain). The paper biome keeps them terrain, as the world of
before biomes was, byte for byte.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ..biomes import biome_of
from ..geometry2d import Rect, yaw_towards
from ..heightfield import Ellipse, EllipseWindow, Flatten, Heightfield, Pit
from ..plan import Clearance, SiteOffer, WorldPlan, ZoneShape, rounded
from ..shapes.primitives import box

STAGE = "cave"
RAMP_HALF_WIDTH = 1.5  # m, the flat part of the ramp out of the pit
RAMP_BLEND = 1.5  # m, its side slopes
# Cave ground steeper than 40 deg is a rock face: no loose soil stands on it. The angle of
# repose, the steepest slope unconsolidated material holds, is 32-36 deg for coarse scree
# (encyclopedia.com, "angle of repose", https://www.encyclopedia.com/science/dictionaries-
# thesauruses-pictures-and-press-releases/angle-repose) and 25-40 deg for regolith (Hunter
# College CUNY, physical geography ch. 8 "Mass wasting", http://www.geo.hunter.cuny.edu/bight/
# chap8.html), so steeper ground is the rock the pit is cut in. The ramp's flat part, the
# pit's way out, is at most 33-35 deg (seeds 0-3), below it; the walls mostly over 50 deg.
ROCK_FACE_TAN = 0.8390996311772800  # tan 40 deg


@dataclass
class Cave(ZoneShape):
    pit: Ellipse
    depth: float  # m below the plateau (before the field is normalised)
    ramp_length: float  # m beyond the pit's end where the ramp reaches the plateau
    plateau_radius: float  # m, the flattened ground around the pit
    roof_u: tuple[float, float]  # pit-local extent of the roof along the pit's axis
    roof_v: tuple[float, float]  # and across it

    def under_roof(self, u, v, margin: float = 0.0):
        """True at pit-local (u, v) under the roof grown by `margin` metres."""
        return (
            (u > self.roof_u[0] - margin)
            & (u < self.roof_u[1] + margin)
            & (v > self.roof_v[0] - margin)
            & (v < self.roof_v[1] + margin)
        )

    def floor_z(self, plan: WorldPlan) -> float:
        return plan.cave_level - self.depth * plan.heightfield.scale

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        """The pit with its walls, the ramp and the roof (an element there would be hidden
        under the roof or stand on a wall)."""
        radius = need.radius
        u, v = self.pit.local(x, y)
        a, b = self.pit.a + radius + 0.8, self.pit.b + radius + 0.8
        ua, vb = u / a, v / b
        bad = ua * ua + vb * vb < 1.0
        bad |= (u > 0) & (u < self.pit.a + self.ramp_length + radius) & (np.abs(v) < 3.5 + radius)
        bad |= self.under_roof(u, v, radius)
        return bad

    def bare(self, x, y) -> np.ndarray:
        """The cave itself, where nothing grows: the pit with its walls, the ramp with its side
        slopes, and the ground under the roof (keep_out less an element's margins)."""
        u, v = self.pit.local(x, y)
        bare = self.pit.radius(x, y) < 1.0
        bare |= (u > 0) & (u < self.pit.a + self.ramp_length) & (np.abs(v) < RAMP_HALF_WIDTH + RAMP_BLEND)
        bare |= self.under_roof(u, v)
        return bare

    def rock_faces(self, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """bool per triangle of a terrain mesh: the cave's rock faces, its triangles within the
        cave (bare(): the pit, the ramp with its side slopes, under the roof) steeper than
        ROCK_FACE_TAN. Products and sums only, so the same triangles on every CPU."""
        t = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.intp)]
        normal = dm.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        horizontal = normal[:, 0] * normal[:, 0] + normal[:, 1] * normal[:, 1]
        steep = horizontal > ROCK_FACE_TAN * ROCK_FACE_TAN * (normal[:, 2] * normal[:, 2])
        centre = (t[:, 0] + t[:, 1] + t[:, 2]) / 3.0
        rock = np.zeros(len(t), dtype=bool)
        rock[steep] = self.bare(centre[steep, 0], centre[steep, 1])
        return rock

    def pose_keep_out(self, plan: WorldPlan, x, y, allow_pit: bool) -> np.ndarray:
        """The pit's walls and the roof, unless the pose is one of the sites in the pit."""
        if allow_pit:
            return super().pose_keep_out(plan, x, y, allow_pit)
        u, v = self.pit.local(x, y)
        return (self.pit.radius(x, y) < 1.1) | self.under_roof(u, v)

    def features(self, plan: WorldPlan) -> dict:
        e = self.pit
        return {
            "pit_centre": [rounded(e.cx), rounded(e.cy)],
            "pit_semi_axes": [rounded(e.a), rounded(e.b)],
            "axis_deg": rounded(dm.degrees(e.angle)),
            "floor_z": rounded(self.floor_z(plan)),
            "roof_z": rounded(plan.cave_level),
        }


def draw(rng: np.random.Generator, cell: Rect) -> Cave:
    """A pit somewhere its plateau fits the cell, turned any way, and its roof."""
    a, b = rng.uniform(6.0, 8.0), rng.uniform(3.5, 4.5)
    ramp = 6.0
    plateau = a + ramp + 1.0
    reach = plateau + 3.0
    half_w, half_h = (cell[1] - cell[0]) / 2, (cell[3] - cell[2]) / 2
    mx, my = max(0.0, half_w - reach), max(0.0, half_h - reach)
    cx = (cell[0] + cell[1]) / 2 + rng.uniform(-mx, mx)
    cy = (cell[2] + cell[3]) / 2 + rng.uniform(-my, my)
    pit = Ellipse(cx, cy, a, b, rng.uniform(0, 2 * math.pi))
    depth = rng.uniform(3.0, 3.4)
    # the roof covers the back of the pit, from beyond its far wall to about its middle
    roof_u = (-pit.a - 1.5, -pit.a * rng.uniform(0.0, 0.2))
    roof_v = (-pit.b - 1.5, pit.b + 1.5)
    return Cave(pit, depth, ramp, plateau, roof_u, roof_v)


def shape_terrain(hf: Heightfield, cave: Cave, cell: Rect) -> float:
    """Flatten a round plateau and sink the pit and ramp into it (called by the terrain
    stage); returns the plateau's level in the field as it is before normalising."""
    p = cave.pit
    window = EllipseWindow(Ellipse(p.cx, p.cy, 1.0, 1.0, 0.0), cave.plateau_radius, cave.plateau_radius + 3.0)
    level = hf.mean_over(window, cell)
    hf.features.append(Flatten(window, level))
    hf.features.append(Pit(cave.pit, cave.depth, 0.6, cave.ramp_length, RAMP_HALF_WIDTH, RAMP_BLEND))
    return level


def pose_offers(plan: WorldPlan, rng: np.random.Generator):
    """Inside under the roof (these need --z-start), at the entrance, and on the rim."""
    cave = plan.layout.cave
    c = cave.pit
    floor = cave.floor_z(plan)
    u_in = cave.roof_u[1] - 1.3
    back = (dm.degrees(c.angle) % 360 + 180) % 360  # facing the back wall, under the roof
    for v in (0.0, 1.0, -1.0):
        x, y = c.to_world(u_in, v)
        yield SiteOffer(
            "cave",
            float(x),
            float(y),
            back,
            "inside cave",
            z_start=round(floor + 1.5, 3),
            allow_pit=True,
            min_gap=0.9,
        )
    for v in (0.0, 1.2):
        x, y = c.to_world(cave.roof_u[1] + 1.5, v)
        yield SiteOffer("cave", float(x), float(y), back, "cave entrance", allow_pit=True, min_gap=0.9)
    for ang in np.linspace(0.6, 2 * np.pi - 0.6, 5):
        sin, cos = dm.sincos(float(ang))
        x, y = c.to_world((c.a + 3.0) * cos, (c.b + 3.0) * sin)
        yield SiteOffer("cave", float(x), float(y), yaw_towards(x, y, c.cx, c.cy), "cave rim", min_gap=4.0)


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    """The cave roof: a slab over the back of the pit, resting on the plateau; rock where the
    biome covers the ground (module docstring), terrain in the paper biome."""
    cave = plan.layout.cave
    (u0, u1), (v0, v1) = cave.roof_u, cave.roof_v
    m = box(((u0 + u1) / 2, (v0 + v1) / 2, 0.05), (u1 - u0, v1 - v0, 0.4))
    c = cave.pit
    rock = biome_of(plan.biome).cover
    plan.add_prototype("cave_roof", m)
    plan.add_element(
        STAGE,
        "cave",
        "rock" if rock else "terrain",
        "cave_roof",
        {},
        name="roof" if rock else "",  # not the rocks stage's cave.rock.0001
        location=(c.cx, c.cy, plan.cave_level),
        yaw=c.angle,
        radius=max(u1 - u0, v1 - v0) / 2,
    )
