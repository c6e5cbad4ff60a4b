"""Every setting a user can get wrong, with its name on the command line and in the panel.

Errors name a setting by its library name (core/errors.py); the command line says
`--max-range must be ...` and the add-on's panel "Max range must be ...", both from
this one table. The command-line options (cli/options.py) and the panel's fields
(ui/properties.py) take their names from it too, so an error always names the field
the user sees.
"""

from __future__ import annotations

from typing import NamedTuple

from ..core.errors import UserError


class Setting(NamedTuple):
    flag: str  # the command-line option
    label: str | None = None  # the panel's label (None: not in the panel)


SETTINGS: dict[str, Setting] = {
    # the world
    "seed": Setting("--seed", "Seed"),
    "detail": Setting("--detail", "Detail"),
    "vegetation": Setting("--vegetation", "Vegetation"),
    "zone": Setting("--zone"),
    "world": Setting("--world"),
    "geometry": Setting("--geometry"),
    "map": Setting("--map"),
    "poses": Setting("--poses"),
    "count": Setting("--count"),
    # the pose
    "pose": Setting("--pose", "Pose"),
    "z_start": Setting("--z-start", "Start height"),
    # the sensor
    "rh": Setting("--rh", "r_h"),
    "min_range": Setting("--min-range", "Min range"),
    "max_range": Setting("--max-range", "Max range"),
    "noise": Setting("--noise", "Noise"),
    "noise_seed": Setting("--noise-seed", "Noise seed"),
    "model": Setting("--model", "Model"),
    "divergence": Setting("--divergence", "Divergence"),
    "echoes": Setting("--echoes", "Echoes"),
    "echo_separation": Setting("--echo-separation", "Echo separation"),
    "frame": Setting("--frame", "Frame"),
    "backend": Setting("--backend", "Ray caster"),
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
    # outputs
    "out": Setting("--out", "File"),
    # the benchmark
    "suite": Setting("--suite"),
    "details": Setting("--details"),
    "backends": Setting("--backends"),
    "runs": Setting("--runs"),
    "reference_rays": Setting("--reference-rays"),
    "markdown": Setting("--markdown"),
}


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
