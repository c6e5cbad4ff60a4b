"""Every setting a user can get wrong, declared once: its name on the command line and in
the panel, and for the settings declared in full (the sensor's) its type, limits or allowed
values, default, unit and help.

Errors name a setting by its library name (core/errors.py); the command line says
`--max-range must be ...` and the add-on's panel "Max range must be ...", both from
this one table. The command-line options (cli/options.py), the panel's fields
(ui/properties.py) and a dataset spec's [sensor] checks (app/dataset/spec.py) take their
names, defaults, limits and help from it, so an error always names the field the user sees
and every front end allows the same values. A sensor setting's limits and default are the
device's (`limits(setting, device)`, `default(setting, device)`: core/sensors setting_limits,
which SensorConfig.validate checks too), so no help text states one device's rules as everyone's.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from ..core.errors import UserError
from ..core.sensors import DEFAULT_DEVICE, Device, Limits, device_named, preset_names
from ..core.sensors.config import (
    DEFAULT_MODEL,
    MAX_DIVERGENCE_MRAD,
    MAX_ECHO_SEPARATION,
    MAX_NOISE_SIGMA,
    MODELS,
    setting_defaults,
    setting_limits,
)
from ..core.sensors.load import COLUMN_HEIGHT, MAX_MOUNT_HEIGHT, MIN_MOUNT_HEIGHT
from ..core.sensors.returns import RETURN_MODES

__all__ = ["Limits", "SETTINGS", "Setting", "default", "limits"]


def _per_device(value) -> str:
    """`value(device)` of every preset, for a help text that states no one device's numbers as
    everyone's ("utm30lx-ew 30, vlp16 100, ...")."""
    return ", ".join(f"{name} {value(device_named(name)):g}" for name in preset_names())


class Setting(NamedTuple):
    flag: str  # the command-line option
    label: str | None = None  # the panel's label (None: not in the panel)
    # declared in full (the sensor's settings); None / "" where a setting does not say
    kind: type | None = None  # float, int or str: what a value is
    limits: Limits | None = None  # for a number whose limits no device decides (else limits())
    choices: tuple[str, ...] | None = None  # for a name
    default: Any = None  # the value when none is given (None: decided elsewhere, see help)
    unit: str = ""  # of a number, as messages write it ("m", "deg", "mrad")
    metavar: str | None = None  # the command line's placeholder
    help: str = ""  # what it is, in one phrase without its default (each front end shows that)
    default_help: str = ""  # the command line's "(default ...)" when more than the value needs saying
    rule: str = ""  # what a value must also satisfy beyond its limits, in words


SETTINGS: dict[str, Setting] = {
    # the world
    "seed": Setting("--seed", "Seed"),
    "detail": Setting("--detail", "Detail"),
    "vegetation": Setting("--vegetation", "Vegetation"),
    "biome": Setting("--biome", "Biome"),
    "layout": Setting("--layout", "Layout"),
    "region": Setting("--region", "Region"),
    "lod": Setting("--lod", "Level of detail"),
    "cache": Setting("--cache"),
    "no_cache": Setting("--no-cache"),
    "cache_size": Setting("--cache-size"),
    "zone": Setting("--zone"),
    "world": Setting("--world"),
    "geometry": Setting("--geometry"),
    "map": Setting("--map"),
    "poses": Setting("--poses"),
    "like": Setting("--like"),
    "count": Setting("--count"),
    # the pose
    "pose": Setting("--pose", "Pose"),
    "z_start": Setting("--z-start", "Start height"),
    # the sensor (declared in full; limits and defaults are the device's: limits(), default())
    "rh": Setting(
        "--rh",
        "r_h",
        float,
        unit="deg",
        metavar="DEG",
        help="horizontal resolution r_h in degrees: the step between the device's columns, at least its "
        "finest step, dividing its sweep into whole columns",
        default_help="default: the device's step; " + _per_device(lambda d: d.mount.step_deg),
        rule="dividing the device's sweep into whole columns",
    ),
    "min_range": Setting(
        "--min-range",
        "Min range",
        float,
        unit="m",
        metavar="M",
        help="shortest range kept, metres, from 0 to below the longest",
        default_help="default: the device's; " + _per_device(lambda d: d.ranges.min_m),
        rule="below max_range",
    ),
    "max_range": Setting(
        "--max-range",
        "Max range",
        float,
        unit="m",
        metavar="M",
        help="longest range kept, metres, at most the device's longest: "
        + _per_device(lambda d: d.ranges.max_dark_m),
        default_help="default: the device's; " + _per_device(lambda d: d.ranges.max_m),
    ),
    "noise": Setting(
        "--noise",
        "Noise",
        float,
        unit="m",
        metavar="SIGMA",
        help=f"standard deviation of the Gaussian range noise, metres, 0 (off) to {MAX_NOISE_SIGMA:g}",
        default_help="default: the device's sigma with the paper model ("
        + _per_device(lambda d: d.noise.sigma_m)
        + "); with the realistic model its datasheet's accuracy, by range",
    ),
    "noise_seed": Setting(
        "--noise-seed",
        "Noise seed",
        int,
        default=0,
        metavar="N",
        help="seed of the range noise, independent of the world seed",
    ),
    "model": Setting(
        "--model",
        "Model",
        str,
        choices=MODELS,
        default=DEFAULT_MODEL,
        help="sensor model: paper (one thin ray a beam, intensity = the class reflectivity, as the "
        "paper; default) or realistic (the beam's footprint, up to the device's echoes a beam with mixed "
        "pixels, intensity from reflectivity, incidence and range, datasheet noise; adds the PLY fields "
        "echo, echoes, label_purity and mixed)",
    ),
    "divergence": Setting(
        "--divergence",
        "Divergence",
        float,
        unit="mrad",
        metavar="MRAD",
        help=f"realistic model: full beam divergence in mrad, 0 (a thin ray) to {MAX_DIVERGENCE_MRAD:g}",
        default_help="default: the device's; " + _per_device(lambda d: d.optics.divergence_mrad),
    ),
    "echoes": Setting(
        "--echoes",
        "Echoes",
        int,
        metavar="N",
        help="realistic model: most echoes a beam returns, 1 to the device's most (its return mode may "
        "fix it): " + _per_device(lambda d: d.optics.echoes),
        default_help="default: the device's most",
    ),
    "echo_separation": Setting(
        "--echo-separation",
        "Echo separation",
        float,
        unit="m",
        metavar="M",
        help="realistic model: surfaces farther apart along a beam than this give separate echoes, closer "
        f"ones merge into one mixed range, metres, above 0 and at most {MAX_ECHO_SEPARATION:g}",
        default_help="default: the device's; " + _per_device(lambda d: d.optics.echo_separation_m),
    ),
    "mount_height": Setting(
        "--mount-height",
        "Mount height",
        float,
        unit="m",
        metavar="M",
        help=f"height of the optical centre above the ground the robot stands on, metres, "
        f"{MIN_MOUNT_HEIGHT:g} to {MAX_MOUNT_HEIGHT:g}",
        default_help=f"default {COLUMN_HEIGHT:g}, the paper robot's column; a device file's [mount] "
        "height for its device",
    ),
    "returns": Setting(
        "--returns",
        "Returns",  # the panel scans in the device's default mode
        str,
        choices=RETURN_MODES,
        default=None,
        help="realistic model: which returns a beam reports, as the device's manual defines them: "
        "strongest, last, dual (both, each point's return_type says which; Velodyne: the strongest and "
        "the last, Ouster: the two strongest) or multi (every echo up to --echoes: the UTM-30LX-EW); a "
        "mode the device does not have is an error",
        default_help="default the device's own: strongest for the Velodyne and Ouster presets, multi for "
        "the UTM-30LX-EW",
    ),
    "frame": Setting("--frame", "Frame"),
    "backend": Setting("--backend", "Ray caster"),
    "weather": Setting("--weather", "Weather"),
    "device": Setting("--sensor", "Sensor"),  # the scanner: a preset or a device file (core/sensors)
    # a drive (wildscan drive)
    "trail": Setting("--trail"),
    "waypoints": Setting("--waypoints"),
    "verify": Setting("--verify"),
    "from": Setting("--from"),
    "distance": Setting("--distance"),
    "speed": Setting("--speed"),
    "scans": Setting("--scans"),
    "head": Setting("--head"),
    "wind": Setting("--wind"),
    "wind_seed": Setting("--wind-seed"),
    "bag": Setting("--bag"),
    "ros2_storage": Setting("--ros2-storage"),
    "imu": Setting("--imu"),
    "imu_rate": Setting("--imu-rate"),
    "imu_noise": Setting("--imu-noise"),
    "route": Setting("--route"),
    # outputs
    "out": Setting("--out", "File"),
    "format": Setting("--format", "Format"),
    "ascii": Setting("--ascii", "ASCII"),
    "range_image": Setting("--range-image"),
    # the benchmark
    "suite": Setting("--suite"),
    "details": Setting("--details"),
    "backends": Setting("--backends"),
    "runs": Setting("--runs"),
    "reference_rays": Setting("--reference-rays"),
    "markdown": Setting("--markdown"),
}


def limits(setting: str, device: Device = DEFAULT_DEVICE) -> Limits:
    """The limits of a numeric sensor setting with `device` (core/sensors setting_limits: the
    device's own where the hardware decides)."""
    return setting_limits(device)[setting]


def default(setting: str, device: Device = DEFAULT_DEVICE):
    """A sensor setting's value with `device` when none is given."""
    return setting_defaults(device)[setting]


def command_line_help(setting: str) -> str:
    """The help of a setting declared in full, with its default, as --help shows it."""
    known = SETTINGS[setting]
    if known.kind is str:  # a name: its help says which is the default
        return known.help
    default = known.default_help or (f"default {known.default:g}" if known.default is not None else "")
    return f"{known.help} ({default})" if default else known.help


def panel_help(setting: str) -> str:
    """The panel's tooltip of a setting declared in full (the panel shows the value itself)."""
    text = SETTINGS[setting].help
    return text[:1].upper() + text[1:]


def flag(setting: str) -> str:
    """The command-line name of `setting` (an effect's: --NAME, core/effects/table.py; a name
    neither table has is used as it is)."""
    from ..core.effects.table import ENTRIES

    known = SETTINGS.get(setting)
    return known.flag if known is not None else f"--{setting}" if setting in ENTRIES else setting


def label(setting: str) -> str:
    """The panel's name of `setting`; one it does not show is named in words."""
    known = SETTINGS.get(setting)
    if known is not None and known.label is not None:
        return known.label
    return setting.lstrip("-").replace("_", " ").replace("-", " ").capitalize()


def command_line_message(error: UserError) -> str:
    return error.phrase(flag)


def panel_message(error: BaseException | str) -> str:
    return error.phrase(label) if isinstance(error, UserError) else str(error)
