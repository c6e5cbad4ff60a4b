"""The settings of one scan (numpy only): which device, its resolution r_h, the range window,
the noise, and the physics model that turns rays into points. The device (device.py) is
what the hardware is; these are what a user sets for a scan, validated against it.

Two physics models share the device's beams (`SensorConfig.model`):

  paper       the paper's emulation: one infinitely thin ray per beam, its first hit is the
              point, intensity is the element's Table I reflectivity (which carries the
              label), Gaussian range noise of the device's fixed σ. The default; its files
              never change.
  realistic   the beam as the device sends it (core/footprint.py, core/echoes.py): a
              footprint of `divergence_mrad` sampled by sub-rays, up to `echoes` echoes
              split `echo_separation` apart (closer surfaces merge into one mixed pixel),
              intensity from reflectivity, incidence and range, and the datasheet's range
              accuracy as noise (noise.datasheet_sigma).

The UTM-30LX-EW's values and their sources are in presets/utm30lx-ew.toml.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..checks import one_of
from ..errors import UserError
from .device import Device, Mount
from .load import DEFAULT_DEVICE
from .returns import RETURN_MODES, kept_echoes

MODELS = ("paper", "realistic")
DEFAULT_MODEL = "paper"
MAX_NOISE_SIGMA = 1.0  # m; far past any real rangefinder, and rays are cast 6 sigma past max range
MAX_DIVERGENCE_MRAD = 50.0  # ~3 deg: far wider than any scanning rangefinder's beam
MAX_ECHO_SEPARATION = 10.0  # m
# the settings of the realistic model alone: giving one with the paper model is a mistake
REALISTIC_SETTINGS = ("divergence", "echoes", "echo_separation", "returns")
# every setting of the sensor, as `wildscan scan` and a dataset spec's [sensor] name them
SENSOR_SETTINGS = ("rh", "min_range", "max_range", "noise", "noise_seed", "model", *REALISTIC_SETTINGS)

_D = DEFAULT_DEVICE


@dataclass(frozen=True)
class SensorConfig:
    rh_deg: float = _D.mount.step_deg
    min_range: float = _D.ranges.min_m
    max_range: float = _D.ranges.max_m
    # m; None: the model's own noise (paper: the device's σ; realistic: the datasheet's, by range)
    noise_sigma: float | None = None
    noise_seed: int = 0
    model: str = DEFAULT_MODEL
    # the realistic model's own settings (the paper model has a thin ray and one echo)
    divergence_mrad: float = _D.optics.divergence_mrad
    echoes: int = _D.optics.echoes
    echo_separation: float = _D.optics.echo_separation_m
    device: Device = _D
    # the realistic model drops returns below the device's detection limit (core/realism/lost_returns.py);
    # False only to measure what the step costs (`wildscan bench --suite detection`)
    detection: bool = True
    # the return mode (returns.py: strongest, last, dual, multi); None: the device's default
    returns: str | None = None

    @classmethod
    def for_device(cls, device: Device, **settings) -> "SensorConfig":
        """The settings of a scan with `device`, its own defaults where `settings` are silent."""
        mode = settings.get("returns") or device.optics.return_mode
        defaults = {
            "rh_deg": device.mount.step_deg,
            "min_range": device.ranges.min_m,
            "max_range": device.ranges.max_m,
            "divergence_mrad": device.optics.divergence_mrad,
            # a device with return modes reports as many echoes as its mode (strongest: 1)
            "echoes": kept_echoes(mode, device.optics.echoes)
            if mode in RETURN_MODES
            else device.optics.echoes,
            "echo_separation": device.optics.echo_separation_m,
        }
        return cls(device=device, **{**defaults, **settings})

    @property
    def realistic(self) -> bool:
        return self.model == "realistic"

    @property
    def return_mode(self) -> str:
        """The return mode of the scan (returns.py): the setting, or the device's default."""
        return self.returns or self.device.optics.return_mode

    @property
    def fixed_noise(self) -> float | None:
        """The one σ of every range (metres), or None when σ depends on the range (the
        realistic model's datasheet noise)."""
        if self.noise_sigma is not None:
            return self.noise_sigma
        return None if self.realistic else self.device.noise.sigma_m

    @property
    def max_noise_sigma(self) -> float:
        """The largest σ any range gets: how far past max range rays are cast."""
        fixed = self.fixed_noise
        noise = self.device.noise
        return fixed if fixed is not None else max(pm for _, pm in noise.accuracy) / noise.accuracy_sigmas

    @property
    def sweeps(self) -> int:
        """The number of columns (2D scans, firings) in one 3D scan: M = sweep / r_h of the
        device's mount, times the head's steps when a head carries the device."""
        return column_count(self.rh_deg, self.device)

    @property
    def beams_per_column(self) -> int:
        return self.device.beams.count

    @property
    def beam_count(self) -> int:
        return self.device.beams.count * self.sweeps

    def validate(self) -> "SensorConfig":
        self.device.check_scannable()
        sweep_count(self.rh_deg, self.device.mount)
        one_of(self.model, "model", MODELS)
        _check_finite("min_range", self.min_range, "m")
        _check_finite("max_range", self.max_range, "m")
        if self.noise_sigma is not None:
            _check_finite("noise", self.noise_sigma, "m")
        if self.min_range < 0:
            raise UserError(f"must be >= 0 m, got {self.min_range:g}", setting="min_range", allowed=(0, None))
        limit = self.device.ranges.max_dark_m
        if self.max_range <= 0 or self.max_range > limit:
            raise UserError(
                f"must be in (0, {limit:g}] m (the {self.device.model}'s limit), got {self.max_range:g}",
                setting="max_range",
                allowed=(0, limit),
            )
        if self.min_range >= self.max_range:
            raise UserError(
                f"({self.min_range:g} m) must be below {{max_range}} ({self.max_range:g} m)",
                setting="min_range",
                related=("max_range",),
            )
        if self.noise_sigma is not None and not 0 <= self.noise_sigma <= MAX_NOISE_SIGMA:
            raise UserError(
                f"must be from 0 (off) to {MAX_NOISE_SIGMA:g} m, got {self.noise_sigma:g}",
                setting="noise",
                allowed=(0, MAX_NOISE_SIGMA),
            )
        if not (0 <= int(self.noise_seed) < 2**63):
            raise UserError(
                f"must be an integer in [0, 2^63), got {self.noise_seed}",
                setting="noise_seed",
                allowed=(0, 2**63 - 1),
            )
        self._validate_realistic()
        return self

    def _validate_realistic(self) -> None:
        _check_finite("divergence", self.divergence_mrad, "mrad")
        if not 0 <= self.divergence_mrad <= MAX_DIVERGENCE_MRAD:
            raise UserError(
                f"must be from 0 (a thin ray) to {MAX_DIVERGENCE_MRAD:g} mrad, got {self.divergence_mrad:g}",
                setting="divergence",
                allowed=(0, MAX_DIVERGENCE_MRAD),
            )
        most = self.device.optics.echoes
        if isinstance(self.echoes, bool) or not isinstance(self.echoes, int) or not 1 <= self.echoes <= most:
            raise UserError(
                f"must be a whole number from 1 to {most}, got {self.echoes!r}",
                setting="echoes",
                allowed=(1, most),
            )
        self.check_returns()
        _check_finite("echo_separation", self.echo_separation, "m")
        if not 0 < self.echo_separation <= MAX_ECHO_SEPARATION:
            raise UserError(
                f"must be in (0, {MAX_ECHO_SEPARATION:g}] m, got {self.echo_separation:g}",
                setting="echo_separation",
                allowed=(0, MAX_ECHO_SEPARATION),
            )

    def check_returns(self) -> None:
        """The return mode is one the device has; with modes, `echoes` is the mode's count."""
        optics, mode = self.device.optics, self.return_mode
        if mode not in optics.returns:
            raise UserError(
                f"must be one of {', '.join(optics.returns)} (the {self.device.model}'s return modes), "
                f"got {mode!r}",
                setting="returns",
                allowed=optics.returns,
            )
        if mode != "multi" and self.echoes != kept_echoes(mode, self.echoes):
            raise UserError(
                f"must be {kept_echoes(mode, 0)} for the {self.device.model} in {mode} mode, got "
                f"{self.echoes}: its return mode sets how many echoes a beam gives; choose one with "
                f"{{returns}} ({', '.join(optics.returns)})",
                setting="echoes",
                related=("returns",),
            )

    def to_dict(self) -> dict:
        """The sensor as file headers and sidecars state it. A paper-model scan with the
        default device says exactly what it said before the realistic model and devices
        existed (so its files stay byte for byte the same): a sensor without `scan_model`
        is the paper model, one without `device` the UTM-30LX-EW."""
        beams = self.device.beams
        d = {
            "rh_deg": self.rh_deg,
            "min_range": self.min_range,
            "max_range": self.max_range,
            "noise_sigma": self.fixed_noise,
            "noise_seed": self.noise_seed,
            "model": self.device.name,
        }
        if beams.fan is not None:
            d["rv_deg"] = beams.fan[1]
        d.update(beams_per_2d_scan=beams.count, sweeps=self.sweeps)
        if self.device != DEFAULT_DEVICE:
            d["device"] = self.device.id
        if self.realistic:
            d.update(
                scan_model=self.model,
                divergence_mrad=self.divergence_mrad,
                echoes=self.echoes,
                echo_separation=self.echo_separation,
                noise_model="fixed" if self.noise_sigma is not None else "datasheet",
            )
            if self.device.optics.returns != ("multi",):
                d["returns"] = self.return_mode
            if self.device.detection is not None and self.detection:
                d["detection"] = self.device.detection.describe()
        return d


def _check_finite(setting: str, value: float, unit: str) -> None:
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise UserError(f"must be a finite number of {unit}, got {value}", setting=setting)


def column_count(rh_deg: float, device: Device = DEFAULT_DEVICE) -> int:
    """Columns in one 3D scan: the mount's M, times the head's K device sweeps."""
    m = sweep_count(rh_deg, device.mount)
    return m if device.head is None else m * device.head.steps


def sweep_count(rh_deg: float, mount: Mount = DEFAULT_DEVICE.mount) -> int:
    """M = sweep / r_h (Eq. 1: 180 / r_h), which must come out whole; 1 for a fixed mount."""
    if mount.kind == "fixed":
        return 1
    sweep = mount.sweep_deg
    if not isinstance(rh_deg, (int, float)) or not math.isfinite(rh_deg) or rh_deg <= 0:
        raise UserError(
            f"must be a positive number of degrees dividing {sweep:g} (e.g. 0.25, 0.5, 1, 2), got {rh_deg}",
            setting="rh",
        )
    if rh_deg < mount.min_step_deg:
        raise UserError(
            f"must be at least {mount.min_step_deg:g} deg (finer scans need gigabytes), got {rh_deg:g}",
            setting="rh",
            allowed=(mount.min_step_deg, sweep),
        )
    m = sweep / rh_deg
    whole = round(m)
    if whole < 1 or abs(m - whole) > 1e-9 * max(1.0, m):
        raise UserError(
            f"must divide {sweep:g} into a whole number of 2D scans (e.g. 0.25, 0.5, 1, 2, 4), "
            f"got {rh_deg:g} ({sweep:g}/{rh_deg:g} = {m:g})",
            setting="rh",
        )
    return int(whole)
