"""Every setting a user can get wrong, declared once: its name on the command line and in
the panel, and for the settings declared in full (the sensor's) its type, limits or allowed
values, default, unit and help.

Errors name a setting by its library name (core/errors.py); the command line says
`--max-range must be ...` and the add-on's panel "Max range must be ...", both from
this one table. The command-line options (cli/options.py), the panel's fields
(ui/properties.py) and a dataset spec's [sensor] checks (app/dataset/spec.py) take their
names, defaults, limits and help from it, so an error always names the field the user sees
and every front end allows the same values. The limits are core/sensor.py's constants, read
by name; the core's SensorConfig.validate is what finally decides a sensor.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from ..core import sensor as S
from ..core.errors import UserError


class Limits(NamedTuple):
    """The closed interval [low, high], or (low, high] when `low_open`."""

    low: float
    high: float
    low_open: bool = False


class Setting(NamedTuple):
    flag: str  # the command-line option
    label: str | None = None  # the panel's label (None: not in the panel)
    # declared in full (the sensor's settings); None / "" where a setting does not say
    kind: type | None = None  # float, int or str: what a value is
    limits: Limits | None = None  # for a number
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
    "zone": Setting("--zone"),
    "world": Setting("--world"),
    "geometry": Setting("--geometry"),
    "map": Setting("--map"),
    "poses": Setting("--poses"),
    "count": Setting("--count"),
    # the pose
    "pose": Setting("--pose", "Pose"),
    "z_start": Setting("--z-start", "Start height"),
    # the sensor (declared in full)
    "rh": Setting(
        "--rh",
        "r_h",
        float,
        Limits(S.MIN_RH_DEG, S.SWEEP_DEG),
        default=S.DEFAULT_RH_DEG,
        unit="deg",
        metavar="DEG",
        help=f"horizontal resolution r_h in degrees, at least {S.MIN_RH_DEG:g}; 180/r_h must be whole",
        default_help=f"default {S.DEFAULT_RH_DEG:g}: 180 2D scans, 194,400 beams",
        rule="dividing 180 into whole 2D scans",
    ),
    "min_range": Setting(
        "--min-range",
        "Min range",
        float,
        Limits(0.0, S.MAX_RANGE_LIMIT),
        default=S.DEFAULT_MIN_RANGE,
        unit="m",
        metavar="M",
        help="shortest range kept, metres",
        rule="below max_range",
    ),
    "max_range": Setting(
        "--max-range",
        "Max range",
        float,
        Limits(0.0, S.MAX_RANGE_LIMIT, low_open=True),
        default=S.DEFAULT_MAX_RANGE,
        unit="m",
        metavar="M",
        help=f"longest range kept, metres, at most {S.MAX_RANGE_LIMIT:g}",
        default_help=f"default {S.DEFAULT_MAX_RANGE:g}, the UTM-30LX-EW under sunlight",
    ),
    "noise": Setting(
        "--noise",
        "Noise",
        float,
        Limits(0.0, S.MAX_NOISE_SIGMA),
        default=None,  # the model's own: the paper's DEFAULT_NOISE_SIGMA, the realistic model's datasheet
        unit="m",
        metavar="SIGMA",
        help=f"standard deviation of the Gaussian range noise, metres, 0 (off) to {S.MAX_NOISE_SIGMA:g}",
        default_help=f"default {S.DEFAULT_NOISE_SIGMA:g} with the paper model; with the realistic model the "
        "datasheet's accuracy, +-30 mm to 10 m and +-50 mm beyond, read as 2 sigma: 0.015 and 0.025",
    ),
    "noise_seed": Setting(
        "--noise-seed",
        "Noise seed",
        int,
        Limits(0, 2**63 - 1),
        default=0,
        metavar="N",
        help="seed of the range noise, independent of the world seed",
    ),
    "model": Setting(
        "--model",
        "Model",
        str,
        choices=S.MODELS,
        default=S.DEFAULT_MODEL,
        help="sensor model: paper (one thin ray a beam, intensity = the class reflectivity, as the "
        "paper; default) or realistic (the beam's footprint, up to 3 echoes a beam with mixed pixels, "
        "intensity from reflectivity, incidence and range, datasheet noise; adds the PLY fields echo, "
        "echoes, label_purity and mixed)",
    ),
    "divergence": Setting(
        "--divergence",
        "Divergence",
        float,
        Limits(0.0, S.MAX_DIVERGENCE_MRAD),
        default=S.DEFAULT_DIVERGENCE_MRAD,
        unit="mrad",
        metavar="MRAD",
        help=f"realistic model: full beam divergence in mrad, 0 (a thin ray) to {S.MAX_DIVERGENCE_MRAD:g}",
        default_help=f"default {S.DEFAULT_DIVERGENCE_MRAD:g}, an estimate: the datasheet gives none",
    ),
    "echoes": Setting(
        "--echoes",
        "Echoes",
        int,
        Limits(1, S.MAX_ECHOES),
        default=S.MAX_ECHOES,
        metavar="N",
        help=f"realistic model: most echoes a beam returns, 1 to {S.MAX_ECHOES}",
        default_help=f"default {S.MAX_ECHOES}, the UTM-30LX-EW's multi-echo",
    ),
    "echo_separation": Setting(
        "--echo-separation",
        "Echo separation",
        float,
        Limits(0.0, S.MAX_ECHO_SEPARATION, low_open=True),
        default=S.DEFAULT_ECHO_SEPARATION,
        unit="m",
        metavar="M",
        help="realistic model: surfaces farther apart along a beam than this give separate echoes, closer "
        "ones merge into one mixed range, metres",
    ),
    "returns": Setting(
        "--returns",
        "Returns",  # the panel scans in the device's default mode
        str,
        choices=S.RETURN_MODES,
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
    """The command-line name of `setting` (a name the table lacks is used as it is)."""
    known = SETTINGS.get(setting)
    return known.flag if known is not None else setting


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
