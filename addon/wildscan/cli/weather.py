"""The --weather option of `wildscan scan` and `wildscan drive` (core/effects/weather.py)."""

from __future__ import annotations

from .options import ArgumentParser, Option, add

WEATHER_HELP = (
    "weather between the sensor and the scene, KEY=VALUE[,KEY=VALUE...]: fog=VISIBILITY_M (5..100000), "
    "rain=MM_PER_H (0..500, Marshall-Palmer drops), dust=G_PER_M3 (0..10), snow=MM_PER_H melted (0..100); "
    "e.g. rain=10,fog=200. A dust cloud instead of dust everywhere: dust=G_PER_M3@X,Y,RADIUS[,TOP], a "
    "vertical cylinder around world (X, Y) up to world height TOP (default: all heights), clear air "
    "outside, e.g. dust=0.5@12,-3,8. Returns from the air are points of class particle (15) with a `weather` "
    "field; 0 (or none) is clear air. docs/weather.md"
)


def _check(text: str) -> dict[str, float]:
    from ..core.effects.weather import parse_settings

    return parse_settings(text)


def add_weather(p: ArgumentParser) -> None:
    add(p, Option("weather", dict(default=None, metavar="SPEC"), _check), help=WEATHER_HELP)
