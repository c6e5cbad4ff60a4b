"""The per-scan draws of a dataset spec: the sensor and weather of scan `index` of world
`seed`, fixed values as given, ranges drawn from streams of their own (seeded by world seed,
key and scan index), so adding a key never shifts another's draws."""

from __future__ import annotations

from ...core import sensor as S
from ...core.rng import stage_rng, stage_seed
from .devices import CONFIG_NAMES, DEVICE_KEYS, draw_device, is_default
from .spec import DatasetSpec, SensorSpec, rh_choices


def _draw(value, seed: int, index: int, key: str):
    if not isinstance(value, tuple):
        return value
    rng = stage_rng(seed, f"dataset.sensor.{key}.{index}")
    if key in ("noise_seed", "echoes"):
        return int(rng.integers(value[0], value[1], endpoint=True))
    if key == "rh":
        choices = list(rh_choices(value))
        return choices[int(rng.integers(len(choices)))]
    return float(rng.uniform(value[0], value[1]))


def draw_sensor(spec: SensorSpec, seed: int, index: int) -> S.SensorConfig:
    """The sensor of scan `index` of world `seed`: fixed values as given, ranges drawn."""
    if spec.noise_seed is None:
        noise_seed = stage_seed(seed, f"dataset.noise.{index}") >> 1  # below 2^63
    else:
        noise_seed = _draw(spec.noise_seed, seed, index, "noise_seed")
    if not is_default(spec.device):
        return _device_sensor(spec, seed, index, noise_seed)
    rh = spec.rh if not isinstance(spec.rh, tuple) else _draw(spec.rh, seed, index, "rh")
    if not isinstance(spec.rh, tuple):
        rh = next(rh_choices(rh))  # exactly 180/M, as the spec check found it
    return S.SensorConfig(
        rh_deg=rh,
        min_range=_draw(spec.min_range, seed, index, "min_range"),
        max_range=_draw(spec.max_range, seed, index, "max_range"),
        noise_sigma=_draw(spec.noise, seed, index, "noise"),
        noise_seed=noise_seed,
        model=spec.model,
        divergence_mrad=_draw(spec.divergence, seed, index, "divergence"),
        echoes=_draw(spec.echoes, seed, index, "echoes"),
        echo_separation=_draw(spec.echo_separation, seed, index, "echo_separation"),
        returns=spec.returns,
    ).validate()


def _device_sensor(spec: SensorSpec, seed: int, index: int, noise_seed: int) -> S.SensorConfig:
    """A scan's sensor with a device other than the default: its own rh and ranges where the
    spec gives none."""
    given = {
        CONFIG_NAMES[key]: _draw(getattr(spec, key), seed, index, key)
        for key in DEVICE_KEYS
        if getattr(spec, key) is not None
    }
    realistic = {
        "divergence": "divergence_mrad",
        "echoes": "echoes",
        "echo_separation": "echo_separation",
        "returns": "returns",
    }
    for key, name in realistic.items():
        if spec.model == "realistic" and getattr(spec, key) is not None:
            given[name] = _draw(getattr(spec, key), seed, index, key)
    return S.SensorConfig.for_device(
        draw_device(spec.device, seed, index),
        noise_sigma=_draw(spec.noise, seed, index, "noise"),
        noise_seed=noise_seed,
        model=spec.model,
        **given,
    ).validate()


def draw_weather(spec: "DatasetSpec", seed: int, index: int) -> dict[str, float]:
    """The weather of scan `index` of world `seed`: fixed values as given, ranges drawn from a
    stream of their own (seeded by world seed, key and scan index)."""
    out = {}
    for key, value in spec.weather:
        if isinstance(value, tuple):
            value = float(stage_rng(seed, f"dataset.weather.{key}.{index}").uniform(value[0], value[1]))
        out[key] = value
    return out
