"""Each sensor setting is declared once (app/settings.py) and its limits are the device's own
(core/sensors setting_limits): the command line's options and help, the panel's fields
(ui/properties.py) and a dataset spec's [sensor] checks allow, for every preset, exactly what
that device allows, and no help text states one device's rules as everyone's."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from wildscan.app.dataset.spec import spec_from_dict
from wildscan.app.settings import SETTINGS, command_line_help, default, limits
from wildscan.cli import build_parser, main
from wildscan.cli.options import apply_checks, sensor_of
from wildscan.core.errors import UserError
from wildscan.core.sensors import device_named, preset_names
from wildscan.core.sensors.config import REALISTIC_SETTINGS, SENSOR_SETTINGS

PRESETS = preset_names()
NUMBERS = [k for k in SENSOR_SETTINGS if SETTINGS[k].kind is not str]
# the settings whose highest allowed value is the device's, with the device number it must equal
DEVICE_HIGHS = {
    "rh": lambda d: d.mount.sweep_deg,
    "max_range": lambda d: d.ranges.max_dark_m,
    "min_range": lambda d: d.ranges.max_dark_m,
    "echoes": lambda d: d.optics.echoes,
}


@pytest.mark.parametrize("setting", SENSOR_SETTINGS)
def test_every_sensor_setting_is_declared_in_full_with_each_devices_limits(setting):
    known = SETTINGS[setting]
    assert known.kind in (float, int, str) and known.help and known.label
    assert (known.choices is not None) == (known.kind is str)
    for name in PRESETS if known.kind is not str else ():
        device = device_named(name)
        low, high, low_open = limits(setting, device)
        value = default(setting, device)
        assert (low < value if low_open else low <= value) and value <= high, (name, setting)
        if setting in DEVICE_HIGHS:
            assert high == DEVICE_HIGHS[setting](device), (name, setting)


def test_scan_help_states_every_presets_numbers_and_no_one_devices_rule_as_everyones():
    scan = build_parser().command_parsers["scan"]
    actions = {a.dest: a for a in scan._actions}
    text = " ".join(" ".join(actions[s].help.split()) for s in SENSOR_SETTINGS)
    for rule in ("180/r_h", "at most 30 ", "1 to 3 ", "the UTM-30LX-EW's"):
        assert rule not in text, rule
    for name in PRESETS:
        d = device_named(name)
        assert f"{name} {d.ranges.max_dark_m:g}" in " ".join(actions["max_range"].help.split())
        assert f"{name} {d.optics.echoes:g}" in " ".join(actions["echoes"].help.split())
    for setting in SENSOR_SETTINGS:
        # None: the --sensor device's own (SensorConfig.for_device) unless the setting is no device's
        assert actions[setting].default == SETTINGS[setting].default
        assert actions[setting].help.startswith(command_line_help(setting))


def _command_line_sensor(name: str, setting: str, value, model: str):
    parser = build_parser()
    argv = ["scan", "--seed", "1", "--pose", "0", "0", "0", "--out", "/tmp/x.ply", "--sensor", name]
    argv += ["--model", model, f"--{setting.replace('_', '-')}", f"{value!r}"]
    args = apply_checks(parser.command_parsers["scan"], parser.parse_args(argv))
    return sensor_of(args).validate()


def _panel_sensor(name: str, setting: str, value, model: str):
    from wildscan.ui.properties import field_limits, sensor_from

    device = device_named(name)
    fields = {
        k: default(k, device) for k in ("rh", "min_range", "max_range", "noise", "divergence", "mount_height")
    }
    fields[setting] = value
    settings = SimpleNamespace(
        device=name, model=model, noise_seed=0, datasheet_noise=False, sensor_file="", **fields
    )
    assert field_limits(settings)[setting] == limits(setting, device)
    return sensor_from(settings).validate()


def _spec_sensor(name: str, setting: str, value, model: str):
    return spec_from_dict({"sensor": {"device": name, "model": model, setting: value}})


FRONT_ENDS = {"command line": _command_line_sensor, "panel": _panel_sensor, "SPEC.toml": _spec_sensor}


# the panel has no echoes field: a scan from the panel takes the device's own
# (min_range's highest goes with a max range above it: SensorConfig.validate's own check)
CASES = [
    (f, s) for f in sorted(FRONT_ENDS) for s in ("echoes", "max_range", "rh") if (f, s) != ("panel", "echoes")
]


@pytest.mark.parametrize("front_end, setting", CASES)
def test_every_front_end_allows_each_presets_own_limit_and_refuses_past_it(front_end, setting):
    """A VLP-16's 100 m or 360 deg sweep is allowed where it is the VLP-16, the Hokuyo's 30 m
    refused past the Hokuyo's; what is refused names the setting."""
    check = FRONT_ENDS[front_end]
    model = "realistic" if setting in REALISTIC_SETTINGS else "paper"
    for name in PRESETS:
        device = device_named(name)
        if setting == "echoes" and device.optics.return_mode != "multi":
            continue  # its return mode fixes the echoes (core/sensors/returns.py), not a limit
        high = limits(setting, device).high
        check(name, setting, high if setting != "rh" else device.mount.step_deg, model)
        past = high + 1 if SETTINGS[setting].kind is int else high * 1.01
        with pytest.raises(UserError) as info:
            check(name, setting, past, model)
        assert setting in (info.value.setting, str(info.value)) or f"sensor.{setting}" in str(info.value)


def test_bench_dataset_rh_is_the_shared_option_and_checked_before_any_work(capsys):
    """bench-dataset's --rh was its own float option: 0.7 (not dividing 180) went on to a
    spec check that named SPEC.toml's sensor.rh, not the option typed."""
    assert main(["bench-dataset", "--rh", "0.7"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "wildscan bench-dataset: error: --rh must divide 180 into a whole number of 2D scans "
        "(e.g. 0.25, 0.5, 1, 2, 4), got 0.7 (180/0.7 = 257.143)"
    ]
