"""The Sensor panel's effects (core/effects/table.py): weather's rain, fog, dust and snow, as
`scene.wildscan.weather`, and a field for every effect of one setting, as `scene.wildscan.effects`.

The fields take their units and slider ranges from core/effects/weather.py's KEYS, the one
declaration of the limits; the Scan operator writes them as the text `wildscan scan
--weather` takes ("rain=25,fog=200") and checks them with the same parser, so a value the
command line refuses is refused here with the same words ("Weather rain='600' is out of
range; rain is 0 to 500 mm/h"). 0 is "none" for every field, so a scene saved before the
fields existed scans in clear air.
"""

from __future__ import annotations

from bpy.props import FloatProperty
from bpy.types import PropertyGroup

from ..core.effects.table import simple_entries
from ..core.effects.weather import KEYS, parse_settings

_WHAT = {
    "fog": "Fog: visibility in metres (0: no fog)",
    "rain": "Rain: rate in mm/h, Marshall-Palmer drops (0: no rain)",
    "dust": "Dust: mass concentration in g/m^3 filling the air (0: no dust)",
    "snow": "Snow: rate in mm/h of melted snow (0: no snow)",
}
ORDER = ("rain", "fog", "dust", "snow")  # the panel's order


def _field(key: str) -> FloatProperty:
    """A weather field with the unit and slider range of KEYS[key] (hard limits are left to
    the parser, which names a value out of range as the command line does)."""
    _, unit, low, high = KEYS[key]
    return FloatProperty(
        name=key.capitalize(),
        description=f"{_WHAT[key]}; {'0 or ' if key == 'fog' else ''}{low:g} to {high:g} {unit}",
        default=0.0,
        soft_min=0.0,
        soft_max=high,
        precision=3 if key == "dust" else 1,
    )


class WildScanWeather(PropertyGroup):
    rain: _field("rain")
    fog: _field("fog")
    dust: _field("dust")
    snow: _field("snow")


def _effect_field(entry) -> FloatProperty:
    """The field of an effect of one setting: its title, help and slider range from the table."""
    s = entry.settings[0]
    text = f"{s.help}; {s.low:g} to {s.high:g} {s.unit} (0: off)"
    return FloatProperty(name=entry.title, description=text, default=0.0, soft_min=s.low, soft_max=s.high)


# one field per effect of one setting in the table, so an effect added there is in the panel too
WildScanEffects = type(
    "WildScanEffects",
    (PropertyGroup,),
    {"__annotations__": {e.name: _effect_field(e) for e in simple_entries()}},
)

CLASSES = (WildScanWeather, WildScanEffects)


def effects_from(settings) -> dict[str, float]:
    """The effects of one setting the panel turns on (name -> checked value; {}: none), or the
    command line's UserError for a value out of range."""
    values = {e.name: (e, getattr(settings.effects, e.name)) for e in simple_entries()}
    return {name: e.settings[0].check(float(_number(v)), name) for name, (e, v) in values.items() if v}


def draw_effects(layout, settings) -> None:
    """The Sensor panel's effects box (nothing while the table has no effect of one setting)."""
    entries = simple_entries()
    if entries:
        col = layout.box().column(align=True)
        for entry in entries:
            col.prop(settings.effects, entry.name)


def _number(value: float) -> str:
    """The number the user typed, as the command line would read it: the shortest decimal of
    Blender's single-precision value (properties.typed_value, which imports this module)."""
    import numpy as np

    typed = float(str(np.float32(value)))
    return f"{typed:g}" if float(f"{typed:g}") == typed else repr(typed)


def weather_text(weather) -> str:
    """The --weather text of the fields: "rain=25,fog=200" ("" when every field is 0)."""
    return ",".join(f"{key}={_number(getattr(weather, key))}" for key in ORDER if getattr(weather, key))


def weather_from(settings) -> dict[str, float]:
    """The checked weather of the panel (key -> value; {} clear air), or the command line's
    UserError for a value out of range."""
    return parse_settings(weather_text(settings.weather))


def draw_weather(layout, settings) -> None:
    """The Sensor panel's weather box: one field a key, with its unit."""
    units = dict(rain="Rain (mm/h)", fog="Fog (visibility m)", dust="Dust (g/m^3)", snow="Snow (mm/h)")
    box = layout.box()
    box.label(text="Weather (0: none)")
    col = box.column(align=True)
    for key in ORDER:
        col.prop(settings.weather, key, text=units[key])
