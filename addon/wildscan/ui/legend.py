"""Colour swatches for the Result panel's legend: one custom preview icon per class,
filled with the class's colour tag (docs/architecture.md "Classes")."""

from __future__ import annotations

from ..core.classes import ALL_ELEMENTS

ICON_SIZE = 16
_state = {"previews": None}


def register() -> None:
    import bpy.utils.previews

    if _state["previews"] is not None:
        return
    previews = bpy.utils.previews.new()
    for element in ALL_ELEMENTS:
        rgba = [c / 255.0 for c in element.color] + [1.0]
        swatch = previews.new(f"wildscan_class_{element.id}")
        swatch.icon_size = (ICON_SIZE, ICON_SIZE)
        swatch.icon_pixels_float = rgba * (ICON_SIZE * ICON_SIZE)
        swatch.image_size = (2 * ICON_SIZE, 2 * ICON_SIZE)
        swatch.image_pixels_float = rgba * (4 * ICON_SIZE * ICON_SIZE)
    _state["previews"] = previews


def unregister() -> None:
    import bpy.utils.previews

    if _state["previews"] is not None:
        bpy.utils.previews.remove(_state["previews"])
        _state["previews"] = None


def icon_id(class_id: int) -> int:
    """The swatch's icon id (0 when there is none, e.g. in background mode)."""
    previews = _state["previews"]
    if previews is None:
        return 0
    swatch = previews.get(f"wildscan_class_{class_id}")
    return swatch.icon_id if swatch is not None else 0
