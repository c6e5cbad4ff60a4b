"""Each sensor setting is declared once (app/settings.py) and every front end reads it: the
command line's options, a dataset spec's [sensor] checks and the panel's fields (the panel
is built from it in ui/properties.py; test_addon.py registers and uses it)."""

from __future__ import annotations

import pytest

from wildscan.app.dataset.spec import spec_from_dict
from wildscan.app.settings import SETTINGS, command_line_help
from wildscan.cli import build_parser, main
from wildscan.cli.sensors import DEVICE_DEFAULTS
from wildscan.core import sensor as S
from wildscan.core.errors import UserError

FLOATS = [k for k in S.SENSOR_SETTINGS if SETTINGS[k].kind is float]


@pytest.mark.parametrize("setting", S.SENSOR_SETTINGS)
def test_every_sensor_setting_is_declared_in_full(setting):
    known = SETTINGS[setting]
    assert known.kind in (float, int, str) and known.help and known.label
    assert (known.choices is not None) == (known.kind is str)
    assert (known.limits is not None) == (known.kind is not str)
    if known.limits is not None and known.default is not None:
        low, high, low_open = known.limits
        assert (low < known.default if low_open else low <= known.default) and known.default <= high


def test_the_command_line_takes_defaults_and_help_from_the_declaration():
    scan = build_parser().command_parsers["scan"]
    actions = {a.dest: a for a in scan._actions}
    for setting in S.SENSOR_SETTINGS:
        # None: the --sensor device's own (cli/sensors.py), or the realistic model's
        device_decides = setting in S.REALISTIC_SETTINGS or setting in DEVICE_DEFAULTS
        assert actions[setting].default == (None if device_decides else SETTINGS[setting].default)
        assert actions[setting].help.startswith(command_line_help(setting))
    assert tuple(actions["model"].choices) == SETTINGS["model"].choices


@pytest.mark.parametrize("setting", FLOATS)
def test_a_spec_value_just_past_the_declared_limits_is_refused(setting):
    low, high, low_open = SETTINGS[setting].limits
    sensor = {"model": "realistic"} if setting in S.REALISTIC_SETTINGS else {}
    too_low = low if low_open else low - 1e-6
    for bad in (high * 1.01 + 1e-6, too_low):
        with pytest.raises(UserError) as info:
            spec_from_dict({"sensor": {**sensor, setting: bad}})
        if setting == "max_range" and bad == too_low:
            continue  # no max range of 0 is above a min range (>= 0): that check speaks first
        assert f"sensor.{setting} must be" in str(info.value)
        assert f"at most {high:g}" in str(info.value) or f"to {high:g}" in str(info.value)
    spec_from_dict({"sensor": {**sensor, setting: high if setting != "min_range" else low}})


def test_bench_dataset_rh_is_the_shared_option_and_checked_before_any_work(capsys):
    """bench-dataset's --rh was its own float option: 0.7 (not dividing 180) went on to a
    spec check that named SPEC.toml's sensor.rh, not the option typed."""
    assert main(["bench-dataset", "--rh", "0.7"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "wildscan bench-dataset: error: --rh must divide 180 into a whole number of 2D scans "
        "(e.g. 0.25, 0.5, 1, 2, 4), got 0.7 (180/0.7 = 257.143)"
    ]
