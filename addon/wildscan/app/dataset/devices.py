"""A dataset spec's `[sensor] device`: one preset name or device file, or a list of them drawn
per scan (core/sensors). With a device other than the default, rh, min_range and max_range
default to the device's own and are checked against it (its sweep, its longest range)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from ...core.errors import UserError, shortened
from ...core.rng import stage_rng
from ...core.sensors import DEFAULT_DEVICE, Device, SensorConfig, device_choice

DEFAULT_DEVICE_ID = DEFAULT_DEVICE.id
# the settings whose default (and limits) are the device's
DEVICE_KEYS = ("rh", "min_range", "max_range")
CONFIG_NAMES = {"rh": "rh_deg", "min_range": "min_range", "max_range": "max_range"}


def spec_device(value, where: str) -> str | tuple[str, ...]:
    """`device` as the spec states it (a device file's path made absolute, so a worker
    elsewhere in the folder tree reads the same file), every device checked now."""
    allowed = 'a preset name or device file "NAME.toml", or a list of them (one drawn per scan)'
    names = value if isinstance(value, list) else [value]
    if not names or not all(isinstance(n, str) and n.strip() for n in names):
        raise UserError(f"{where}: sensor.device must be {allowed}, got {shortened(repr(value))}")
    out = []
    for name in names:
        if name.lower().endswith(".toml"):
            name = str(Path(name).expanduser().resolve())
        try:
            device_choice(name).check_scannable()
        except UserError as e:
            raise UserError(f"{where}: sensor.device {e.message if e.setting == 'device' else e}") from None
        out.append(name)
    return out[0] if not isinstance(value, list) else tuple(out)


def device_files(device: str | tuple[str, ...]) -> dict[str, str]:
    """Path -> SHA-256 of the contents of every device file the spec names (presets are part
    of the WildScan version); a file that cannot be read any more is a UserError."""
    out = {}
    for name in device if isinstance(device, tuple) else (device,):
        if name.lower().endswith(".toml"):
            try:
                out[name] = hashlib.sha256(Path(name).read_bytes()).hexdigest()
            except OSError as e:
                raise UserError(f"cannot read the device file {name}: {e.strerror or e}") from None
    return out


def with_device_files(config: dict, device: str | tuple[str, ...]) -> dict:
    """`config` (what a config hash covers) with the device files' contents: an edited file is
    another sensor, so a run resuming with it is refused as for any other change. A spec of
    presets only (part of the WildScan version) keeps the hash it had before files counted."""
    files = device_files(device)
    return {**config, "device_files": files} if files else config


def is_default(device: str | tuple[str, ...]) -> bool:
    return device == DEFAULT_DEVICE_ID


def device_values(data: dict, where: str, device: str | tuple[str, ...]) -> dict:
    """rh, min_range and max_range of a spec with a device other than the default: None (the
    device's own) where not given, a number or (for the ranges) [lo, hi]; every value and
    both ends of every range checked against every device the spec may draw."""
    values = {}
    for key in DEVICE_KEYS:
        value = data.get(key)
        ranged = isinstance(value, list) and key != "rh"
        ok = value is None or _number(value) or (ranged and len(value) == 2 and all(map(_number, value)))
        if not ok or (ranged and value[0] > value[1]):
            what = "a number" if key == "rh" else "a number or a range [lo, hi] (lo <= hi)"
            raise UserError(
                f"{where}: sensor.{key} must be {what} (the device's own when absent), "
                f"got {shortened(repr(value))}"
            )
        values[key] = tuple(float(v) for v in value) if ranged else (None if value is None else float(value))
    for name in device if isinstance(device, tuple) else (device,):
        for end in (0, 1):
            given = {CONFIG_NAMES[k]: (v[end] if isinstance(v, tuple) else v) for k, v in values.items()}
            try:
                SensorConfig.for_device(
                    device_choice(name), **{k: v for k, v in given.items() if v is not None}
                ).validate()
            except UserError as e:
                raise UserError(f"{where}: with device {Path(name).name}, sensor.{e}") from None
    return values


def spec_returns(data: dict, where: str, device: str | tuple[str, ...]) -> str | None:
    """A spec's `returns` (None: each device's own), checked against every device the spec may
    draw (core/sensors/returns.py): a mode one of them lacks is a mistake before any work."""
    mode = data.get("returns")
    if mode is None:
        return None
    for name in device if isinstance(device, tuple) else (device,):
        try:
            SensorConfig.for_device(device_choice(name), model="realistic", returns=mode).check_returns()
        except UserError as e:
            raise UserError(f"{where}: with device {Path(name).name}, sensor.{e}") from None
    return mode


def draw_device(device: str | tuple[str, ...], seed: int, index: int) -> Device:
    """The device of scan `index` of world `seed`: the one named, or one of the list drawn
    from a stream of its own."""
    if isinstance(device, tuple):
        device = device[int(stage_rng(seed, f"dataset.sensor.device.{index}").integers(len(device)))]
    return device_choice(device)


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)
