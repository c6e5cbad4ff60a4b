"""Build the world for a seed in the current scene: what `--seed`, `wildscan world`
and the add-on's Generate button all call."""
from __future__ import annotations

from typing import Callable

DETAILS = ("low", "default", "high")


def generate_world(seed: int, detail: str = "default", progress: Callable[[str, float], None] | None = None):
    """Replace what WildScan built before (only that) with the world of `seed`.

    Until the procedural world builder lands this builds the small test world;
    `detail` is accepted for the same signature.
    """
    from .testworld import build_test_world

    return build_test_world(seed)
