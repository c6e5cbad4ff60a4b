"""`wildscan sensors` (the presets, one line each) and the `--sensor NAME|FILE.toml` option of
`wildscan scan` and `wildscan drive` (core/sensors: a device is data)."""

from __future__ import annotations

import argparse

from .options import ArgumentParser, Option, add

HELP = "list the sensor presets (--sensor NAME): beams, field of view, range, rate, source"
DESCRIPTION = (
    "Every device preset with its beams, field of view, range, revolution (or 3D scan) rate and the "
    "datasheet or calibration file its numbers come from. --sensor NAME picks one for `wildscan scan` and "
    "`wildscan drive`; --sensor FILE.toml reads a device file written the same way (docs/sensors.md)."
)
SENSOR_HELP = (
    "the scanner: a preset name (utm30lx-ew, the default: the paper's rotating Hokuyo; `wildscan sensors` "
    "lists the others) or a device file FILE.toml (docs/sensors.md). The sensor options' limits and "
    "defaults are the device's own"
)


def _device(text: str):
    from ..core.sensors import device_choice

    return device_choice(text)


def add_sensor(p: ArgumentParser) -> None:
    """--sensor: its value is checked (the device loaded) before any work."""
    add(
        p,
        Option("device", dict(default=None, dest="device", metavar="NAME|FILE.toml"), _device),
        help=SENSOR_HELP,
    )


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    p.add_argument("--markdown", action="store_true", help="print a Markdown table (docs/sensors.md)")


def rows() -> list[tuple[str, ...]]:
    """(preset, device, beams, field of view, range, rate, source) of every preset."""
    from ..core.sensors import device_named, preset_names

    out = []
    for name in preset_names():
        d = device_named(name)
        out.append(
            (
                name,
                d.name,
                str(d.beams.count),
                _field_of_view(d),
                f"{d.ranges.min_m:g}-{d.ranges.max_m:g} m (at most {d.ranges.max_dark_m:g})",
                _sweep(d),
                d.source,
            )
        )
    return out


def _sweep(d) -> str:
    if d.head is not None:  # a 3D scan is the head's turn: K device sweeps
        seconds = d.head.steps * d.sweep_period_s
        return f"{d.head.sweep_deg:g} deg head turn in {seconds:.4g} s ({d.head.steps} device sweeps)"
    return f"{d.mount.sweep_deg:g} deg in {d.sweep_period_s:.4g} s ({1 / d.sweep_period_s:.3g} Hz)"


def _field_of_view(d) -> str:
    if d.head is not None:
        return _head_field_of_view(d)
    if d.beams.fan is not None:
        first, step = d.beams.fan
        return f"{d.beams.count * step:g} deg fan, {step:g} deg apart x {d.mount.sweep_deg:g} deg turn"
    low, high = d.vertical_fov_deg
    return f"{low:+.2f} to {high:+.2f} deg x {d.mount.sweep_deg:g} deg, {d.mount.step_deg:.7g} deg columns"


def _head_field_of_view(d) -> str:
    """A device on a head: the elevations its beams reach over the head's turn (sensor frame)."""
    import numpy as np

    from ..core.sensors import beam_directions

    z = beam_directions(d.mount.step_deg, d)[0][:, 2]
    low, high = np.degrees(np.arcsin(np.clip([z.min(), z.max()], -1.0, 1.0)))
    return (
        f"tilted {d.head.tilt_deg:g} deg on a head turning {d.head.sweep_deg:g} deg: elevations {low:+.2f} "
        f"to {high:+.2f} deg, {d.mount.step_deg:.7g} deg columns"
    )


HEADERS = ("preset", "device", "beams", "field of view", "range", "sweep", "source")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    table = rows()
    if args.markdown:
        print("| " + " | ".join(HEADERS) + " |")
        print("|" + "---|" * len(HEADERS))
        for row in table:
            print("| " + " | ".join(row) + " |")
        return 0
    for name, device, beams, fov, ranges, sweep, source in table:
        print(f"{name:11} {device}: {beams} beams, {fov}; {ranges}; {sweep}")
        print(f"{'':11} source: {source}")
    return 0
