"""Effects (numpy only): what changes a scan besides the scene and the sensor: the medium a
beam crosses before it hits (weather: fog, rain, dust, snow) and the scene at a time (wind).
base.py says what an effect is; `Effects()` (CLEAR_AIR) is no effect, today's bytes."""

from .base import CLEAR_AIR, Effect, Effects, ObjectMotion, Rays
from .weather import Weather, weather_of
from .wind import Wind

__all__ = ["CLEAR_AIR", "Effect", "Effects", "ObjectMotion", "Rays", "Weather", "Wind", "weather_of"]
