"""The classes a dataset lists (its card, labels.yaml, class weights): core/classes.py's one
answer, `listed_classes`, over the dataset's points and what its scans' effects declare."""

from __future__ import annotations

from ...core.classes import BY_ID, ElementClass, listed_classes


def declared_classes(weather, biome: str) -> tuple[int, ...]:
    """The optional class ids a dataset's scans declare (Effect.classes) from the effects each
    scan gets (app/scan.py scan_effects): the ground cover's where the biome has a ground layer,
    weather's where the spec has [weather]."""
    from ...core.effects import Weather
    from ...core.effects.cover import GroundCover
    from ...core.effects.weather import weather_on
    from ...core.world.biomes import biome_of

    effects = ((GroundCover, biome_of(biome).cover), (Weather, weather_on(weather)))
    return tuple(i for effect, on in effects if on for i in effect.classes)


def dataset_classes(
    weather, biome: str, class_points: dict[str, int] | None = None
) -> tuple[ElementClass, ...]:
    """The classes a dataset lists: its scans' declared ones and those its points carry
    (`class_points`: points per class name, the card's totals)."""
    ids = {c.name: c.id for c in BY_ID.values()}
    carried = [ids[name] for name, n in (class_points or {}).items() if n]
    return listed_classes(carried, declared_classes(weather, biome))
