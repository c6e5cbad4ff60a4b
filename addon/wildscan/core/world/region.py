"""Layouts and regions: which world a seed gives, and which part of it a command builds.

Two layouts (DESIGN.md, "Contracts of this round's issues"): `endless`, the default, a
landscape that is a pure function of the seed and the position, built in square tiles where
they are needed; and `paper`, the 150 m six-zone island of the paper (with `--biome paper`,
the golden bytes). A region is an axis-aligned rectangle in the world frame (metres); the
default region of `world`, `extract` and `poses` is the paper island's square around the
origin on either layout, so a command that names no region builds what it built before.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..checks import one_of
from ..errors import UserError
from ..placement import MAX_COORDINATE
from .plan import HALF

LAYOUTS = ("endless", "paper")
DEFAULT_LAYOUT = "endless"

# The most a side of a built region may span. A region is built whole at full detail: the
# endless world's default detail holds ~100-150 triangles a square metre where it is wooded
# (a 100 m forest tile of seed 1: 1.4-1.6 M triangles, ~110 MB as a scan or a file holds
# them), so a 400 m square is up to ~24 M triangles, ~1.8 GB: what the 2-core machines
# WildScan targets (a few GB) hold. A scan never needs a region: it builds the tiles within
# the sensor's reach.
MAX_REGION_SIDE = 400.0  # m


def check_layout(layout: str) -> str:
    return one_of(layout, "layout", LAYOUTS)


class Region(NamedTuple):
    """xmin, ymin, xmax, ymax in metres, world frame."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    @property
    def centre(self) -> tuple[float, float]:
        return (0.5 * (self.xmin + self.xmax), 0.5 * (self.ymin + self.ymax))

    @property
    def size(self) -> tuple[float, float]:
        return (self.xmax - self.xmin, self.ymax - self.ymin)

    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax): the order core/world's EXTENT uses."""
        return (self.xmin, self.xmax, self.ymin, self.ymax)

    def contains(self, other: Region) -> bool:
        return (
            self.xmin <= other.xmin
            and self.ymin <= other.ymin
            and self.xmax >= other.xmax
            and self.ymax >= other.ymax
        )

    def to_dict(self) -> dict:
        return {"xmin": self.xmin, "ymin": self.ymin, "xmax": self.xmax, "ymax": self.ymax}

    def text(self) -> str:
        return f"{self.xmin:g} {self.ymin:g} {self.xmax:g} {self.ymax:g}"


DEFAULT_REGION = Region(-HALF, -HALF, HALF, HALF)


def region_around(x: float, y: float, size: float) -> Region:
    """The square of side `size` centred on (x, y) (the add-on's centre and size)."""
    h = 0.5 * float(size)
    return Region(float(x) - h, float(y) - h, float(x) + h, float(y) + h)


def check_region(values, layout: str = DEFAULT_LAYOUT) -> Region:
    """Four numbers XMIN YMIN XMAX YMAX as a Region, or UserError saying what is wrong: not
    finite, inverted or empty, a side over MAX_REGION_SIDE, or (paper layout) outside the
    island, which has nothing beyond its 150 m square."""
    values = tuple(float(v) for v in values)
    if len(values) != 4:
        raise UserError(f"takes four numbers XMIN YMIN XMAX YMAX, got {len(values)}", setting="region")
    if not all(math.isfinite(v) for v in values):
        raise UserError(f"must be finite numbers, got {' '.join(f'{v:g}' for v in values)}", setting="region")
    region = Region(*values)
    if region.xmax <= region.xmin or region.ymax <= region.ymin:
        raise UserError(
            f"must have XMIN < XMAX and YMIN < YMAX (XMIN YMIN XMAX YMAX), got {region.text()}",
            setting="region",
        )
    if max(abs(v) for v in values) > MAX_COORDINATE:
        raise UserError(f"must lie within +-{MAX_COORDINATE:g} m, got {region.text()}", setting="region")
    width, height = region.size
    if max(width, height) > MAX_REGION_SIDE:
        raise UserError(
            f"is {width:g} m x {height:g} m: a side may span at most {MAX_REGION_SIDE:g} m (build a "
            "larger area as several regions; a scan needs no region, it builds what it reaches)",
            setting="region",
            allowed=(None, MAX_REGION_SIDE),
        )
    if layout == "paper" and not DEFAULT_REGION.contains(region):
        raise UserError(
            f"{region.text()} leaves the paper layout's island ({DEFAULT_REGION.text()}); "
            "the endless layout has ground everywhere",
            setting="region",
            related=(),
        )
    return region


def reach_beyond(region: Region, x: float, y: float, reach: float) -> float:
    """How far (m) the disc of radius `reach` around (x, y) leaves `region`: 0 when inside."""
    return max(
        0.0,
        region.xmin - (x - reach),
        (x + reach) - region.xmax,
        region.ymin - (y - reach),
        (y + reach) - region.ymax,
    )


def extended_region(region: Region, x: float, y: float, reach: float) -> Region:
    """The region grown to hold the disc of radius `reach` around (x, y) (the add-on's Extend);
    when that would pass MAX_REGION_SIDE, the square around the disc alone (the sensor's reach
    is what a scan there needs), itself at most MAX_REGION_SIDE."""
    grown = Region(
        min(region.xmin, x - reach),
        min(region.ymin, y - reach),
        max(region.xmax, x + reach),
        max(region.ymax, y + reach),
    )
    if max(grown.size) <= MAX_REGION_SIDE:
        return grown
    return region_around(x, y, min(2.0 * reach, MAX_REGION_SIDE))


def dataset_layout(value, where: str = "SPEC.toml") -> str:
    """A dataset spec's `layout`: "endless", its default (poses over a region of the landscape,
    weighed by land cover), or "paper" (the island's six zones, today's datasets byte for byte)."""
    if value is None:
        return DEFAULT_LAYOUT
    if value not in LAYOUTS:
        raise UserError(
            f"{where}: layout must be one of {', '.join(repr(v) for v in LAYOUTS)}, got {value!r}"
        )
    return value
