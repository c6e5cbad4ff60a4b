"""SPEC.toml: what a dataset is made of (a contract: docs/datasets.md lists every key).

Every key is optional with a default; an unknown key or a bad value is a UserError
naming the key and what is allowed. Sensor values may be a fixed value or a range
[lo, hi] drawn per scan from a stream seeded by (world seed, scan index, key), and the
value drawn is recorded with the scan.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import asdict, dataclass, field, replace

from ... import __version__
from ...core.checks import Table, is_int, is_number, show
from ...core.errors import UserError
from ...core.io.files import user_path
from ...core.io.formats import FORMATS
from ...core.label_schemes import SCHEME_NAMES
from ...core.realism.intensity import DEFAULT_DATASET_INTENSITY, INTENSITY_MODES
from ...core.rng import stage_seed
from ...core.sensors import DEFAULT_DEVICE
from ...core.sensors.config import DEFAULT_MODEL, REALISTIC_SETTINGS, SENSOR_SETTINGS
from ...core.spatial.frames import FRAMES
from ...core.world import BIOMES, DEFAULT_BIOME, DEFAULT_VEGETATION, DETAILS, MAX_SEED, VEGETATION
from ...core.world.region import DEFAULT_LAYOUT, dataset_layout
from ..settings import SETTINGS, default, limits
from .devices import DEVICE_KEYS, device_values, is_default, spec_device, spec_limits, spec_returns
from .effects_spec import effects_table, weather_table
from .like import with_like
from .pose_spec import DEFAULT_LAND_MIN_SCANS, DEFAULT_ZONE_WEIGHTS, POSE_CLASSES, PoseSpec, poses_table

__all__ = ["DEFAULT_ZONE_WEIGHTS", "POSE_CLASSES", "DatasetSpec", "PoseSpec", "SensorSpec", "load_spec"]

# what a spec without `formats` writes: fixed, so a format added to the table (core/io/formats.py)
# changes no existing spec's files or config hash
DEFAULT_FORMATS = ("semantickitti", "las", "ply")
SPLITS = ("train", "val", "test")
MAX_SCANS_PER_WORLD = 100_000
MAX_WORLDS = 100_000
Value = float | tuple[float, float]
TOP_KEYS = ("seeds", "detail", "vegetation", "biome", "scans_per_world", "formats", "label_scheme")
TOP_KEYS += ("split", "poses", "sensor", "weather", "effects", "intensity", "layout")  # layout: region.py


@dataclass(frozen=True)
class SensorSpec:
    rh: Value = default("rh")  # the default device's
    min_range: Value = default("min_range")
    max_range: Value = default("max_range")
    noise: Value | None = None  # None: the model's own (paper 0.015 m; realistic the datasheet's)
    noise_seed: int | tuple[int, int] | None = None  # None: a seed of its own per scan
    frame: str = "leveled"
    model: str = DEFAULT_MODEL
    # the realistic model's own settings (as `wildscan scan`: a mistake with model "paper")
    divergence: Value = default("divergence")
    echoes: int | tuple[int, int] = default("echoes")
    echo_separation: Value = default("echo_separation")
    mount_height: Value | None = None  # m (or a range); None: the device's own [mount] height
    returns: str | None = None  # the return mode (core/sensors/returns.py); None: the device's own
    # a preset or device file, or a tuple of them drawn per scan (app/dataset/devices.py); with
    # another device than the default, rh, min_range and max_range are None for its own
    device: str | tuple[str, ...] = "utm30lx-ew"


@dataclass(frozen=True)
class DatasetSpec:
    seeds: tuple[int, ...] = (0, 1, 2)
    detail: str = "default"
    vegetation: str = DEFAULT_VEGETATION
    biome: str = DEFAULT_BIOME  # core/world/biomes.py; paper: the world from before biomes
    scans_per_world: int = 50
    formats: tuple[str, ...] = DEFAULT_FORMATS
    label_scheme: str = "wildscan"
    split: tuple[tuple[str, float], ...] = (("train", 0.8), ("val", 0.1), ("test", 0.1))
    # the endless default's poses: class-aware for its rare classes (app/dataset/pose_spec.py)
    poses: PoseSpec = field(default_factory=lambda: PoseSpec(min_scans_with=DEFAULT_LAND_MIN_SCANS))
    sensor: SensorSpec = field(default_factory=SensorSpec)
    # [weather]: key (core/effects/weather.py KEYS) -> a value or a range [lo, hi] drawn per scan
    weather: tuple[tuple[str, Value], ...] = ()
    effects: tuple[tuple[str, Value], ...] = ()  # [effects]: name (core/effects/table.py) -> value or range
    intensity: str = DEFAULT_DATASET_INTENSITY  # "physical" or "class" (core/realism/intensity.py)
    layout: str = DEFAULT_LAYOUT  # "endless" or "paper" (core/world/region.py)

    def to_dict(self) -> dict:
        out = json.loads(json.dumps(asdict(self)))
        if self.layout == "paper":  # a paper spec keeps the dict, so the config hash, of before layouts
            del out["layout"]
            out["poses"] = json.loads(json.dumps(self.poses.paper_dict()))
        else:  # the island's keys mean nothing on the endless layout
            for key in ("strategy", "zones"):
                del out["poses"][key]
        for key in ("weather", "effects"):  # a spec without them keeps its dict, so its config hash
            if not getattr(self, key):
                del out[key]
        if not self.poses.min_scans_with:  # the same for class-aware poses
            del out["poses"]["min_scans_with"]
        for key, unset in (("device", SensorSpec.device), ("mount_height", None)):
            if out["sensor"][key] == unset:  # and one with the default device, at its height
                del out["sensor"][key]
        return out

    def config_hash(self) -> str:
        """SHA-256 of the spec with every default filled in, the WildScan version and the
        contents of its device files (app/dataset/devices.py with_device_files)."""
        from .devices import with_device_files

        config = with_device_files({"spec": self.to_dict(), "wildscan": __version__}, self.sensor.device)
        return hashlib.sha256(json.dumps(config, sort_keys=True).encode()).hexdigest()

    def sequence_of(self, seed: int) -> str:
        return f"{self.seeds.index(seed):02d}"

    def splits(self) -> dict[int, str]:
        """World seed -> split. Counts by largest remainder; which worlds by a seeded order."""
        shares = dict(self.split)
        n = len(self.seeds)
        exact = {s: n * shares.get(s, 0.0) for s in SPLITS}
        count = {s: math.floor(exact[s]) for s in SPLITS}
        for s in sorted(SPLITS, key=lambda s: (-(exact[s] - count[s]), SPLITS.index(s)))[
            : n - sum(count.values())
        ]:
            count[s] += 1
        order = sorted(self.seeds, key=lambda seed: stage_seed(seed, "dataset.split"))
        out, start = {}, 0
        for s in SPLITS:
            for seed in order[start : start + count[s]]:
                out[seed] = s
            start += count[s]
        return out

    def empty_split_warning(self) -> str | None:
        """One line when a split with a share above 0 gets no world (too few seeds for its
        share: the default three seeds all go to train), else None."""
        shares = dict(self.split)
        counts = {s: 0 for s in SPLITS}
        for split in self.splits().values():
            counts[split] += 1
        empty = [s for s in SPLITS if shares.get(s, 0.0) > 0 and counts[s] == 0]
        if not empty:
            return None
        given = ", ".join(f"{s} {counts[s]}" for s in SPLITS)
        named = " and ".join(f"{s} (share {shares[s]:g})" for s in empty)
        one = len(empty) == 1
        seeds = "1 seed gives" if len(self.seeds) == 1 else f"{len(self.seeds)} seeds give"
        return (
            f"{'split' if one else 'splits'} {named} {'gets' if one else 'get'} no world: "
            f"{seeds} {given}; give more seeds or set {'its share' if one else 'their shares'} to 0"
        )


def load_spec(path, like: str | None = None) -> DatasetSpec:
    """SPEC.toml at `path` (None: every default), `like` (--like) in place of its own."""
    try:
        import tomllib
    except ImportError:  # Python 3.10: the same parser as a package (the `dataset` extra)
        import tomli as tomllib

    if path is None:
        return spec_from_dict({"like": like} if like else {}, "--like")
    path = user_path(path, "spec", "a spec file name")
    try:
        text = path.read_bytes()
    except OSError as e:
        raise UserError(f"cannot read the spec {path}: {e.strerror or e}") from None
    try:
        data = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise UserError(f"{path.name}: not valid TOML ({e})") from None
    return spec_from_dict(data | ({"like": like} if like else {}), path.name)


def spec_from_dict(data: dict, where: str = "SPEC.toml") -> DatasetSpec:
    top = Table(with_like(data, where), "", where)  # `like`: a real dataset's rig and files
    top.only(*TOP_KEYS)
    d = DatasetSpec()
    layout = dataset_layout(top.data.get("layout"), where)
    if layout == "endless" and top.data.get("biome") == "paper":
        # an endless dataset's ground truth reads its terrain from the tiles' ground cover grid,
        # which the paper biome (bare ground, the worlds of before) does not have
        raise UserError(
            f'{where}: biome = "paper" (the world from before biomes) is the island\'s: give '
            'layout = "paper", or another biome (mixed, meadow, forest, scrub) for a dataset over the '
            "endless landscape"
        )
    return replace(
        d,
        layout=layout,
        seeds=_seeds(top),
        detail=top.choice("detail", tuple(DETAILS), default=d.detail),
        vegetation=top.choice("vegetation", VEGETATION, default=d.vegetation),
        biome=top.choice("biome", BIOMES, default=d.biome),
        scans_per_world=top.integer("scans_per_world", 1, MAX_SCANS_PER_WORLD, default=d.scans_per_world),
        formats=_formats(top),
        label_scheme=top.choice("label_scheme", SCHEME_NAMES, default=d.label_scheme),
        split=_split(top.table("split", dict(d.split))),
        poses=poses_table(top.table("poses", {}), layout),
        sensor=_sensor(top.table("sensor", {})),
        weather=weather_table(top.table("weather", {})),
        effects=effects_table(top.table("effects", {})),
        intensity=top.choice("intensity", INTENSITY_MODES, default=d.intensity),
    )


# "A..B" with ASCII digits only: str.isdigit() also takes "²" or "٣", which int() refuses
_SEED_RANGE = re.compile(r"\s*([0-9]+)\s*\.\.\s*([0-9]+)\s*")


def _seeds(t: Table) -> tuple[int, ...]:
    value = t.get("seeds", list(DatasetSpec().seeds))
    allowed = f'a list of world seeds (whole numbers from 0 to {MAX_SEED}) or a range "A..B"'
    seeds: list = []
    if isinstance(value, str):
        seeds = _seed_range(t, value, allowed)
    elif isinstance(value, list):
        seeds = value
    ok = seeds and all(is_int(s) and 0 <= s <= MAX_SEED for s in seeds) and len(seeds) <= MAX_WORLDS
    if not ok or len(set(seeds)) != len(seeds):
        extra = " without repeats" if ok else ""
        raise t.fail("seeds", f"{allowed}{extra}, at most {MAX_WORLDS:,} worlds", value)
    return tuple(seeds)


def _seed_range(t: Table, value: str, allowed: str) -> list[int]:
    """The seeds of "A..B" (inclusive), its size checked before a list is made of it (a
    range of millions would take seconds and gigabytes only to be refused)."""
    match = _SEED_RANGE.fullmatch(value)
    if not match or int(match[1]) > int(match[2]):
        return []
    a, b = int(match[1]), int(match[2])
    if b > MAX_SEED or b - a + 1 > MAX_WORLDS:
        raise UserError(
            f"{t.where}: seeds must be {allowed} of at most {MAX_WORLDS:,} worlds from 0 to {MAX_SEED}, "
            f"got {show(value)} ({b - a + 1:,} worlds)"
        )
    return list(range(a, b + 1))


def _formats(t: Table) -> tuple[str, ...]:
    value = t.get("formats", list(DEFAULT_FORMATS))
    if (
        not isinstance(value, list)
        or not value
        or any(v not in FORMATS for v in value)
        or len(set(value)) != len(value)
    ):
        allowed = ", ".join(f'"{f}"' for f in FORMATS)
        raise t.fail("formats", f"a non-empty list of {allowed} (each once)", value)
    return tuple(f for f in FORMATS if f in value)


def _split(t: Table) -> tuple[tuple[str, float], ...]:
    t.only(*SPLITS)
    shares = {s: t.number(s, 0.0, 1.0, default=0.0) for s in SPLITS}
    if abs(sum(shares.values()) - 1.0) > 1e-9:
        raise UserError(
            f"{t.where}: split shares must add up to 1 (train + val + test), got {sum(shares.values()):g}"
        )
    return tuple(shares.items())


# the sensor values that may be numbers or ranges of numbers, with their limits the device's
RANGED_SENSOR_KEYS = tuple(k for k in SENSOR_SETTINGS if SETTINGS[k].kind is float)
# the keys of [sensor]: the sensor settings of `wildscan scan` and the frame
SENSOR_KEYS = (*SENSOR_SETTINGS, "frame")


def _sensor(t: Table) -> SensorSpec:
    t.only(*SENSOR_KEYS, "device")
    device = spec_device(t.get("device", SensorSpec.device), t.where)
    own = () if is_default(device) else DEVICE_KEYS  # the settings the device decides
    d = SensorSpec()
    model = t.choice("model", SETTINGS["model"].choices, default=d.model)
    for key in REALISTIC_SETTINGS:
        if key in t.data and model != "realistic":
            raise UserError(
                f'{t.where}: {t.name(key)} applies to model = "realistic" only (sensor.model is "{model}")'
            )
    values = {
        key: _sensor_value(t, key, getattr(d, key), device)
        for key in RANGED_SENSOR_KEYS
        if key not in own and (key not in ("noise", "mount_height") or t.get(key, None) is not None)
    }
    if own:
        values.update(device_values(t.data, t.where, device))
    elif not any(True for _ in rh_choices(values["rh"])):
        raise t.fail(
            "rh", "a value (or range) holding an r_h that divides 180 into whole 2D scans", t.get("rh", None)
        )
    if not own and _hi(values["min_range"]) >= _lo(values["max_range"]):
        raise UserError(
            f"{t.where}: sensor.min_range must stay below sensor.max_range (every value of each range)"
        )
    for key, value in values.items():
        if key not in own:
            _check_open_low(t, key, value)
    values.update(
        echoes=_whole_value(t, "echoes", None if own else d.echoes, device),
        returns=spec_returns(t.data, t.where, device),
    )
    if own:  # the realistic model's settings not given are the device's own too
        values.update({key: None for key in REALISTIC_SETTINGS if key not in t.data})
    return SensorSpec(
        **values,
        device=device,
        noise_seed=_whole_value(t, "noise_seed", None, device),
        frame=t.choice("frame", FRAMES, default=d.frame),
        model=model,
    )


def _check_open_low(t: Table, key: str, value: Value) -> None:
    """A setting whose lowest value is excluded ((0, 30] m): not there, nor in a range."""
    low, high, low_open = limits(key, DEFAULT_DEVICE)  # another device: devices.py checks its own
    if low_open and _lo(value) <= low:
        raise t.fail(
            key,
            f"above {low:g} and at most {high:g} {SETTINGS[key].unit} (or a range of such)",
            t.get(key, None),
        )


def _lo(v: Value) -> float:
    return v[0] if isinstance(v, tuple) else v


def _hi(v: Value) -> float:
    return v[1] if isinstance(v, tuple) else v


def _sensor_value(t: Table, key: str, default: float, device) -> Value:
    setting = SETTINGS[key]
    low, high, _ = spec_limits(key, device)
    unit = f"{setting.unit} {setting.rule}" if key == "rh" else setting.unit
    value = t.get(key, default)
    allowed = f"a number from {low:g} to {high:g} {unit}, or a range [lo, hi] of such numbers"
    if isinstance(value, list):
        if (
            len(value) != 2
            or not all(is_number(v) and low <= v <= high for v in value)
            or value[0] > value[1]
        ):
            raise t.fail(key, allowed + " with lo <= hi", value)
        return (float(value[0]), float(value[1]))
    if not is_number(value) or not low <= value <= high:
        raise t.fail(key, allowed, value)
    return float(value)


def _whole_value(t: Table, key: str, default, device):
    """A whole number within the setting's limits, or a range [lo, hi] of such (drawn per scan)."""
    low, high, _ = spec_limits(key, device)
    value = t.get(key, default)
    if value is None:
        return None
    allowed = f"a whole number from {low} to {high}, or a range [lo, hi] of such"
    if isinstance(value, list):
        if len(value) != 2 or not all(is_int(v) and low <= v <= high for v in value) or value[0] > value[1]:
            raise t.fail(key, allowed, value)
        return (value[0], value[1])
    if not is_int(value) or not low <= value <= high:
        raise t.fail(key, allowed, value)
    return value


def rh_choices(rh: Value, mount=DEFAULT_DEVICE.mount):
    """The r_h values allowed by a fixed value or range: the mount's sweep / M for whole M."""
    lo, hi, sweep = _lo(rh), _hi(rh), mount.sweep_deg
    for m in range(
        max(1, math.ceil(sweep / hi - 1e-9)), math.floor(sweep / max(lo, mount.min_step_deg) + 1e-9) + 1
    ):
        value = sweep / m
        if lo - 1e-9 <= value <= hi + 1e-9:
            yield value


def spec_from_json(data: dict) -> DatasetSpec:
    """The inverse of DatasetSpec.to_dict (specs travel to Dask workers as plain data)."""

    def value(v):  # JSON's lists back to tuples, nested ones too ([[zone, weight], ...])
        return tuple(value(x) for x in v) if isinstance(v, list) else v

    poses, sensor = data["poses"], data["sensor"]
    return DatasetSpec(
        seeds=tuple(data["seeds"]),
        detail=data["detail"],
        vegetation=data["vegetation"],
        biome=data.get("biome", DEFAULT_BIOME),
        scans_per_world=data["scans_per_world"],
        formats=tuple(data["formats"]),
        label_scheme=data["label_scheme"],
        split=tuple((k, v) for k, v in data["split"]),
        poses=PoseSpec(**{k: value(v) for k, v in poses.items()}),
        sensor=SensorSpec(**{k: value(v) for k, v in sensor.items()}),
        weather=tuple((k, value(v)) for k, v in data.get("weather", [])),
        effects=tuple((k, value(v)) for k, v in data.get("effects", [])),
        intensity=data.get("intensity", DEFAULT_DATASET_INTENSITY),
        layout=data.get("layout", "paper"),  # a paper spec's dict names no layout (to_dict)
    )
