"""SPEC.toml's [poses] table: where a dataset's scans stand (docs/datasets.md lists every key).

The paper layout weighs its island's six `zones`; the endless layout draws its poses over a
`region` of the landscape, weighed by land `cover` (core/world/endless LAND_COVERS), standing
where a robot drives unless `tall_cover` asks for a share in tall grass, reeds or undergrowth.
A key of the other layout is a mistake named as such, never silently ignored.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from ...core.checks import Table, is_number, show
from ...core.classes import TAG_NAMES
from ...core.errors import UserError
from ...core.posesampler import STRATEGIES
from ...core.world import ZONES
from ...core.world.endless.fields import LAND_COVERS

POSE_CLASSES = tuple(n for n in TAG_NAMES if n != "water")  # what [poses] min_scans_with may name
DEFAULT_ZONE_WEIGHTS = (
    ("hills", 1.0),
    ("forest", 2.0),
    ("park", 1.0),
    ("lake", 1.0),
    ("cave", 1.0),
    ("trail", 1.0),
)
# The endless landscape's land covers (add, never rename); by default forest weighs twice the others.
DEFAULT_COVER_WEIGHTS = tuple((c, 2.0 if c == "forest" else 1.0) for c in LAND_COVERS)
# The endless default's class-aware poses: the classes a landscape holds only in a few places
# (park furniture in the clearings, the power lines' poles and wires, mud by the lakes, paved
# paths, rock slab on the outcrops), drawn near in these shares of the scans so that a default
# spec has each class in at least 15 % of its scans. Measured on the default spec (seeds 0-2,
# 50 scans each, `wildscan dataset`, the card's "Scans containing a class") with table and pole
# at 0.15 only: fence 8.5 %, paved 11.3 %, mud 13.4 %, pole 13.4 % (seed 0's square has no
# power line); a bench stands by every table, wires hang from the poles. The other classes
# were in 19-100 % of the scans without help; `terrain` in none (the landscape's ground is
# always a material: soil, leaf litter, low grass, mud...).
DEFAULT_LAND_MIN_SCANS = (
    ("table", 0.2),
    ("fence", 0.1),
    ("pole", 0.25),
    ("mud", 0.15),
    ("paved", 0.1),
    ("rock slab", 0.1),
)
# The default region on the endless layout: a 1 km square around each seed's origin.
DEFAULT_REGION_HALF = 500.0  # m
# A region's corners stay this far inside the landscape's reach (core/world/endless/tiles.py
# MAX_TILE_INDEX x TILE_M = 9 km): a scan builds the tiles ~35 m around its pose.
REGION_LIMIT = 8900.0  # m
MIN_REGION_SIDE = 10.0  # m: a pose keeps 2 m from the region's edge (app/poses.py EDGE_MARGIN)
PAPER_ONLY = ("strategy", "zones")
ENDLESS_ONLY = ("region", "cover", "tall_cover")


@dataclass(frozen=True)
class PoseSpec:
    strategy: str = "zones"
    zones: tuple[tuple[str, float], ...] = DEFAULT_ZONE_WEIGHTS
    min_distance: float = 2.0
    # class -> share of a world's scans drawn near its elements (core/posesampler.py)
    min_scans_with: tuple[tuple[str, float], ...] = ()
    # the endless layout's: XMIN, YMIN, XMAX, YMAX (None: the default square), cover weights and
    # the share of poses in tall cover
    region: tuple[float, float, float, float] | None = None
    cover: tuple[tuple[str, float], ...] = DEFAULT_COVER_WEIGHTS
    tall_cover: float = 0.0

    def paper_dict(self) -> dict:
        """The fields the paper layout reads: what its config hash and world cache key hold,
        as before the endless layout's keys existed."""
        out = asdict(self)
        for key in ENDLESS_ONLY:
            del out[key]
        return out

    def land_region(self) -> tuple[float, float, float, float]:
        h = DEFAULT_REGION_HALF
        return self.region if self.region is not None else (-h, -h, h, h)


def poses_table(t: Table, layout: str) -> PoseSpec:
    """[poses] of a spec of `layout`: its keys checked, each layout's own only."""
    t.only(*PAPER_ONLY, *ENDLESS_ONLY, "min_distance", "min_scans_with")
    other = ENDLESS_ONLY if layout == "paper" else PAPER_ONLY
    for key in other:
        if key in t.data:
            own = ", ".join(f"poses.{k}" for k in (PAPER_ONLY if layout == "paper" else ENDLESS_ONLY))
            theirs = "endless" if layout == "paper" else "paper"
            raise UserError(
                f'{t.where}: {t.name(key)} applies to layout = "{theirs}" only; this spec\'s layout is '
                f'"{layout}" (its poses take {own})'
            )
    d = PoseSpec()
    if layout == "paper" or "min_scans_with" in t.data:  # class -> share 0..1 of the scans
        shares = t.table("min_scans_with", {})
        shares.only(*POSE_CLASSES)
        min_scans = tuple(
            (c, shares.number(c, 0.0, 1.0, default=0.0)) for c in POSE_CLASSES if c in shares.data
        )
    else:  # on by default on the endless layout (`min_scans_with = {}` turns it off)
        min_scans = DEFAULT_LAND_MIN_SCANS
    common = {
        "min_distance": t.number("min_distance", 0.0, 50.0, default=d.min_distance),
        "min_scans_with": min_scans,
    }
    if layout == "paper":
        return PoseSpec(
            strategy=t.choice("strategy", STRATEGIES, default=d.strategy), zones=_zones(t), **common
        )
    return PoseSpec(
        region=_region(t),
        cover=_weights(t, "cover", LAND_COVERS, d.cover, "land cover"),
        tall_cover=t.number("tall_cover", 0.0, 1.0, default=d.tall_cover),
        **common,
    )


def _zones(t: Table) -> tuple[tuple[str, float], ...]:
    return _weights(t, "zones", ZONES, DEFAULT_ZONE_WEIGHTS, "zone")


def _weights(t: Table, key: str, names: tuple[str, ...], default, what: str) -> tuple[tuple[str, float], ...]:
    table = t.table(key, dict(default))
    table.only(*names)
    weights = tuple((n, table.number(n, 0.0, 1e9, default=0.0)) for n in names if n in table.data)
    if not any(w > 0 for _, w in weights):
        raise UserError(f"{t.where}: {t.name(key)} must give at least one {what} a weight above 0")
    return weights


def _region(t: Table) -> tuple[float, float, float, float] | None:
    value = t.get("region")
    if value is None:
        return None
    allowed = (
        f"four numbers [XMIN, YMIN, XMAX, YMAX] in metres with XMIN < XMAX and YMIN < YMAX, each side at "
        f"least {MIN_REGION_SIDE:g} m, within ±{REGION_LIMIT:g} m of the origin"
    )
    if (
        not isinstance(value, list)
        or len(value) != 4
        or not all(is_number(v) and math.isfinite(v) for v in value)
    ):
        raise t.fail("region", allowed, value)
    x0, y0, x1, y1 = (float(v) for v in value)
    if (
        x1 - x0 < MIN_REGION_SIDE
        or y1 - y0 < MIN_REGION_SIDE
        or max(map(abs, (x0, y0, x1, y1))) > REGION_LIMIT
    ):
        raise UserError(f"{t.where}: {t.name('region')} must be {allowed}, got {show(value)}")
    return (x0, y0, x1, y1)
