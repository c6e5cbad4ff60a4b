"""Device files (TOML) -> Device (numpy only). A wrong value is a UserError naming the file,
the key, the value and what is allowed; an unknown key is one too (a typo never passes
silently as a default).

    [beams]   kind = "fan": count, first_deg, step_deg (θ = first + n·step from the axis, one
              plane; ring n is beam n), or kind = "table": elevation_deg = [...] and
              azimuth_offset_deg = [...] per beam (ring 0 = the lowest elevation)
    [timing]  column_period_s, steps_per_column, beam_step = [...] (a fan: beam n at step n)
    [range]   min_m, max_m, max_dark_m
    [noise]   sigma_m, accuracy = [[up_to_m, plus_minus_m], ...], accuracy_sigmas
    [optics]  divergence_mrad, echoes, echo_separation_m, and (optional) returns = [...] (the
              return modes, returns.py; default ["multi"]), return_mode (the default mode),
              dual (what the dual mode pairs)
    [mount]   kind, axis, tilt_deg, step_deg, min_step_deg, sweep_deg, heads, direction (optional:
              "ccw", the default, or "cw")
    [head]    (optional) axis, tilt_deg, step_deg, sweep_deg, turn: a rotating head carrying
              the device (device.py)
    [detection] (optional) pairs = [[reflectance, range_m], ...], estimate = [reflectance, ...]:
              the datasheet's detection ranges (detection.py); every preset has one
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from ..errors import UserError, shortened
from .detection import detection_from_table
from .device import (
    HEAD_MODES,
    HEAD_TURNS,
    MOUNT_KINDS,
    TURN_DIRECTIONS,
    BeamTable,
    Device,
    Head,
    Mount,
    Noise,
    Optics,
    RangeLimits,
    Timing,
)
from .returns import DUAL_PAIRS, KEPT, RETURN_MODES

PRESETS_DIR = Path(__file__).resolve().parent / "presets"
DEFAULT_DEVICE_ID = "utm30lx-ew"
MAX_BEAMS = 4096  # beams a column: far past any lidar made (the largest have 128)
MAX_STEPS_PER_COLUMN = 1_000_000
MAX_HEAD_STEPS = 3600  # device sweeps a 3D scan on a head (0.05 deg steps over 180 deg)


def preset_names() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in PRESETS_DIR.glob("*.toml")))


@functools.lru_cache(maxsize=16)
def device_named(name: str) -> Device:
    """The preset `name` (presets/NAME.toml)."""
    if name not in preset_names():
        raise UserError(
            f"must be one of {', '.join(preset_names())} or a device file NAME.toml, "
            f"got {shortened(repr(name))}",
            setting="device",
            allowed=preset_names(),
        )
    return load_device(PRESETS_DIR / f"{name}.toml")


def device_choice(text: str) -> Device:
    """A preset by name, or a device file (a path ending in .toml): what `--sensor` and a
    dataset spec's `device` take."""
    text = str(text)
    if text.lower().endswith(".toml"):
        return load_device(Path(text).expanduser())
    return device_named(text)


def load_device(path) -> Device:
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise UserError(f"cannot read the device file {path}: {getattr(e, 'strerror', None) or e}") from None
    return device_from_text(text, path.name)


def device_from_text(text: str, where: str = "device.toml") -> Device:
    toml = toml_reader()
    try:
        data = toml.loads(text)
    except toml.TOMLDecodeError as e:
        raise UserError(f"{where}: not valid TOML ({e})") from None
    return device_from_dict(data, where)


def toml_reader():
    """tomllib, or on Python 3.10 the same parser as a package (tomli), or, with neither (the
    Python of Blender 3.4-4.0), the plain TOML of the presets (simple_toml.py)."""
    try:
        import tomllib
    except ImportError:
        try:
            import tomli as tomllib
        except ImportError:
            from . import simple_toml as tomllib
    return tomllib


def device_from_dict(data: dict, where: str = "device.toml") -> Device:
    top = _Table(data, "", where)
    top.only(
        "id",
        "vendor",
        "model",
        "source",
        "beams",
        "timing",
        "range",
        "noise",
        "optics",
        "mount",
        "head",
        "detection",
    )
    beams = _beams(top.table("beams"))
    ranges = _ranges(top.table("range"))
    return Device(
        id=top.text("id"),
        vendor=top.text("vendor"),
        model=top.text("model"),
        beams=beams,
        timing=_timing(top.table("timing"), beams),
        ranges=ranges,
        noise=_noise(top.table("noise"), ranges),
        optics=_optics(top.table("optics")),
        mount=_mount(top.table("mount")),
        head=_head(top.table("head")) if "head" in data else None,
        source=top.text("source") if "source" in data else "",
        detection=detection_from_table(top.table("detection")) if "detection" in data else None,
    )


def _beams(t: "_Table") -> BeamTable:
    kind = t.choice("kind", ("fan", "table"))
    if kind == "fan":
        t.only("kind", "count", "first_deg", "step_deg")
        count = t.integer("count", 1, MAX_BEAMS)
        first = t.number("first_deg", -180.0, 180.0)
        step = t.number("step_deg", 0.0, 360.0, low_open=True)
        if first + (count - 1) * step > 180.0:
            raise t.fail(
                "step_deg",
                f"at most {(180.0 - first) / max(count - 1, 1):g} (the last beam within 180 deg)",
                step,
            )
        # θn = n·step + first in float64, exactly Eq. 1's arithmetic (beams.py takes these values)
        angles = (np.arange(count, dtype=np.float64) * step + first).tolist()
        return BeamTable(tuple(angles), (0.0,) * count, tuple(range(count)), fan=(first, step))
    t.only("kind", "elevation_deg", "azimuth_offset_deg")
    elevation = t.numbers("elevation_deg", -90.0, 90.0, 1, MAX_BEAMS)
    azimuth = t.numbers("azimuth_offset_deg", -180.0, 180.0, len(elevation), len(elevation))
    ring = np.argsort(np.argsort(np.asarray(elevation), kind="stable"), kind="stable")
    return BeamTable(tuple(90.0 - e for e in elevation), tuple(azimuth), tuple(int(r) for r in ring))


def _timing(t: "_Table", beams: BeamTable) -> Timing:
    t.only("column_period_s", "steps_per_column", "beam_step")
    period = t.number("column_period_s", 0.0, 10.0, low_open=True)
    if abs(round(period * 1e9) * 1e-9 - period) > 1e-15:
        raise t.fail("column_period_s", "a whole number of nanoseconds (bag stamps are exact)", period)
    steps = t.integer("steps_per_column", 1, MAX_STEPS_PER_COLUMN)
    if "beam_step" in t.data:
        beam_step = t.integers("beam_step", 0, steps - 1, beams.count, beams.count)
    elif beams.fan is None:
        raise t.fail("beam_step", f"a list of {beams.count} steps (one a beam) from 0 to {steps - 1}", None)
    elif beams.count > steps:
        raise t.fail("steps_per_column", f"at least the fan's {beams.count} beams (one a step)", steps)
    else:
        beam_step = tuple(range(beams.count))  # a fan's mirror meets beam n at step n
    return Timing(period, steps, beam_step)


def _ranges(t: "_Table") -> RangeLimits:
    t.only("min_m", "max_m", "max_dark_m")
    dark = t.number("max_dark_m", 0.0, 10_000.0, low_open=True)
    low = t.number("min_m", 0.0, dark)
    high = t.number("max_m", low, dark, low_open=True)
    return RangeLimits(low, high, dark)


def _noise(t: "_Table", ranges: RangeLimits) -> Noise:
    t.only("sigma_m", "accuracy", "accuracy_sigmas")
    sigma = t.number("sigma_m", 0.0, 1.0)
    rows = t.get("accuracy")
    shape = "a list of [up to m, +- m] pairs, ranges rising to max_dark_m, +- from 0 to 1 m"
    if not isinstance(rows, list) or not rows:
        raise t.fail("accuracy", shape, rows)
    table = []
    for row in rows:
        if not (isinstance(row, list) and len(row) == 2 and all(_is_number(v) for v in row)):
            raise t.fail("accuracy", shape, rows)
        up_to, pm = float(row[0]), float(row[1])
        if not (0 <= pm <= 1) or (table and up_to <= table[-1][0]) or up_to <= 0:
            raise t.fail("accuracy", shape, rows)
        table.append((up_to, pm))
    if table[-1][0] < ranges.max_dark_m:
        raise t.fail(
            "accuracy", f"{shape} (the last row reaches {table[-1][0]:g}, not {ranges.max_dark_m:g})", rows
        )
    return Noise(sigma, tuple(table), t.number("accuracy_sigmas", 0.0, 10.0, low_open=True))


def _optics(t: "_Table") -> Optics:
    t.only("divergence_mrad", "echoes", "echo_separation_m", "returns", "return_mode", "dual")
    echoes = t.integer("echoes", 1, 3)  # the realistic model forms at most three echoes
    modes = t.get("returns", ["multi"])
    listed = ", ".join(f'"{m}"' for m in RETURN_MODES if m != "multi")
    if not isinstance(modes, list) or not modes or modes != ["multi"] and not set(modes) <= set(KEPT):
        raise t.fail("returns", f'["multi"] (every echo up to `echoes`) or a list of {listed}', modes)
    mode = t.choice("return_mode", tuple(modes)) if "return_mode" in t.data else modes[0]
    dual = t.choice("dual", DUAL_PAIRS) if "dual" in modes else None
    if "dual" not in modes and "dual" in t.data:
        raise t.fail("dual", 'given only with "dual" in returns', t.get("dual"))
    if modes != ["multi"] and echoes != max(KEPT[m] for m in modes):
        most = max(KEPT[m] for m in modes)
        raise t.fail(
            "echoes", f"{most}, the most returns a beam its modes report ({', '.join(modes)})", echoes
        )
    return Optics(
        divergence_mrad=t.number("divergence_mrad", 0.0, 50.0),
        echoes=echoes,
        echo_separation_m=t.number("echo_separation_m", 0.0, 10.0, low_open=True),
        returns=tuple(modes),
        return_mode=mode,
        dual=dual,
    )


def _mount(t: "_Table") -> Mount:
    t.only("kind", "axis", "tilt_deg", "step_deg", "min_step_deg", "sweep_deg", "heads", "direction")
    axis = t.numbers("axis", -1.0, 1.0, 3, 3)
    if abs(math.fsum(a * a for a in axis) - 1.0) > 1e-9:
        raise t.fail("axis", "a unit vector [x, y, z]", list(axis))
    sweep = t.number("sweep_deg", 0.0, 360.0, low_open=True)
    min_step = t.number("min_step_deg", 0.0, sweep, low_open=True)
    heads = t.get("heads", list(HEAD_MODES))
    if not isinstance(heads, list) or not heads or any(h not in HEAD_MODES for h in heads):
        raise t.fail("heads", "a list of " + ", ".join(f'"{h}"' for h in HEAD_MODES), heads)
    return Mount(
        kind=t.choice("kind", MOUNT_KINDS),
        axis=tuple(float(a) for a in axis),
        tilt_deg=t.number("tilt_deg", -90.0, 90.0),
        step_deg=t.number("step_deg", min_step, sweep),
        min_step_deg=min_step,
        sweep_deg=sweep,
        heads=tuple(heads),
        direction=t.choice("direction", TURN_DIRECTIONS) if "direction" in t.data else "ccw",
    )


def _head(t: "_Table") -> Head:
    t.only("axis", "tilt_deg", "step_deg", "sweep_deg", "turn")
    axis = t.numbers("axis", -1.0, 1.0, 3, 3)
    if abs(math.fsum(a * a for a in axis) - 1.0) > 1e-9:
        raise t.fail("axis", "a unit vector [x, y, z]", list(axis))
    sweep = t.number("sweep_deg", 0.0, 360.0, low_open=True)
    step = t.number("step_deg", 0.0, sweep, low_open=True)
    steps = sweep / step
    if abs(steps - round(steps)) > 1e-9 * max(1.0, steps) or round(steps) > MAX_HEAD_STEPS:
        whole = f"a step dividing sweep_deg {sweep:g} into 1 to {MAX_HEAD_STEPS} whole steps"
        raise t.fail("step_deg", whole, step)
    return Head(
        axis=tuple(float(a) for a in axis),
        tilt_deg=t.number("tilt_deg", -180.0, 180.0),
        step_deg=step,
        sweep_deg=sweep,
        turn=t.choice("turn", HEAD_TURNS),
    )


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _show(value) -> str:
    if value is None:
        return "nothing"
    return f'"{shortened(value)}"' if isinstance(value, str) else shortened(value)


class _Table:
    """One TOML table with its dotted name, for messages that say which key is wrong."""

    def __init__(self, data: dict, prefix: str, where: str):
        self.data, self.prefix, self.where = data, prefix, where

    def fail(self, key: str, allowed: str, value) -> UserError:
        return UserError(f"{self.where}: {self.prefix}{key} must be {allowed}, got {_show(value)}")

    def only(self, *keys: str) -> None:
        for key in self.data:
            if key not in keys:
                table = f"[{self.prefix[:-1]}]" if self.prefix else "the top level"
                raise UserError(
                    f"{self.where}: unknown key {self.prefix}{key!s}; allowed in {table}: {', '.join(keys)}"
                )

    def get(self, key: str, default=None):
        return self.data.get(key, default)

    def table(self, key: str) -> "_Table":
        value = self.data.get(key)
        if not isinstance(value, dict):
            raise self.fail(key, "a table", value)
        return _Table(value, f"{self.prefix}{key}.", self.where)

    def text(self, key: str) -> str:
        value = self.data.get(key)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, "a name in quotes", value)
        return value

    def choice(self, key: str, allowed: tuple[str, ...]) -> str:
        value = self.data.get(key)
        if value not in allowed:
            raise self.fail(key, "one of " + ", ".join(f'"{a}"' for a in allowed), value)
        return value

    def integer(self, key: str, low: int, high: int) -> int:
        value = self.data.get(key)
        if not (isinstance(value, int) and not isinstance(value, bool) and low <= value <= high):
            raise self.fail(key, f"a whole number from {low} to {high}", value)
        return value

    def number(self, key: str, low: float, high: float, low_open: bool = False) -> float:
        value = self.data.get(key)
        if not _is_number(value) or not (low < value if low_open else low <= value) or value > high:
            bound = "above" if low_open else "from"
            raise self.fail(
                key, f"a number {bound} {low:g} {'and at most' if low_open else 'to'} {high:g}", value
            )
        return float(value)

    def numbers(self, key: str, low: float, high: float, least: int, most: int) -> tuple[float, ...]:
        value = self.data.get(key)
        count = f"{least}" if least == most else f"{least} to {most}"
        if (
            not isinstance(value, list)
            or not least <= len(value) <= most
            or not all(_is_number(v) and low <= v <= high for v in value)
        ):
            raise self.fail(key, f"a list of {count} numbers from {low:g} to {high:g}", value)
        return tuple(float(v) for v in value)

    def integers(self, key: str, low: int, high: int, least: int, most: int) -> tuple[int, ...]:
        value = self.data.get(key)
        if not isinstance(value, list) or not least <= len(value) <= most:
            raise self.fail(key, f"a list of {least} whole numbers from {low} to {high}", value)
        for v in value:
            if not (isinstance(v, int) and not isinstance(v, bool) and low <= v <= high):
                raise self.fail(key, f"a list of {least} whole numbers from {low} to {high}", value)
        return tuple(value)


DEFAULT_DEVICE = device_named(DEFAULT_DEVICE_ID)
