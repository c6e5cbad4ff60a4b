"""Build the world for a seed in the current scene: what `wildscan scan --seed`
and the add-on's Generate button call (`wildscan world` also saves it)."""

from __future__ import annotations

from typing import Callable

from ..core.world import DETAILS as _DETAIL_LEVELS

DETAILS = tuple(_DETAIL_LEVELS)  # the names, low to high


def generate_world(seed: int, detail: str = "default", progress: Callable[[str, float], None] | None = None):
    """Replace what WildScan built before (only that) with the world of `seed`.

    `progress(stage, seconds)` is called after each build stage.
    """
    from .builder import build_world

    return build_world(seed, detail, progress=progress)
