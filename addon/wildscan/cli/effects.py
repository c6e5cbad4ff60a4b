"""The effects' options of `wildscan scan` and `wildscan drive`, built from the effects table
(core/effects/table.py): --weather "rain=10,fog=200" (weather's own text), and --NAME VALUE
for each effect of one setting (0: off)."""

from __future__ import annotations

import argparse

from .options import ArgumentParser, Option, add, finite_float


def _entries():
    from ..core.effects.table import ENTRIES

    return ENTRIES.values()


def _option(entry) -> Option:
    if entry.parse is not None:  # weather's KEY=VALUE text
        return Option(entry.name, dict(default=None, metavar="SPEC", help=entry.help), entry.parse)
    setting = entry.settings[0]
    metavar = setting.key.upper()
    return Option(
        entry.name,
        dict(default=None, type=finite_float, metavar=metavar, help=entry.help),
        lambda value: setting.check(value, entry.name),
    )


def add_effects(p: ArgumentParser) -> None:
    for entry in _entries():
        add(p, _option(entry))


def effect_values(args: argparse.Namespace) -> dict[str, float]:
    """The effects of one setting the command line turns on (name -> value; none: {})."""
    return {e.name: getattr(args, e.name) for e in _entries() if e.parse is None and getattr(args, e.name)}
