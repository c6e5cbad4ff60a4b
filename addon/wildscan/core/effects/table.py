"""The one table of effects a user sets (numpy only): name -> EffectEntry (base.py), read by
the command line (`wildscan scan` and `wildscan drive`: cli/effects.py), a dataset's SPEC.toml
and the add-on's panel, as the formats table (core/io/formats.py) is by the writers' users.

Adding an effect (docs/extending.md "Add an effect"): a module in core/effects/ with an Effect
subclass and its `ENTRY = EffectEntry(...)`, and its name as one line in ENTRIES below. An effect of one
setting gets `--NAME VALUE` on the command line, `NAME = VALUE` in SPEC.toml's [effects] (or a
range [lo, hi], drawn per scan) and a field in the panel's Effects box; 0 is off. Weather, of
several settings, has its own forms of the same entry (--weather "rain=10,fog=200", [weather]).
The order of ENTRIES is the order a scan applies the effects in: add new ones at the end.
"""

from __future__ import annotations

from importlib import import_module

from .base import Effect, EffectEntry


def _table(*modules: str) -> dict[str, EffectEntry]:
    """name -> the ENTRY of each module of core/effects named (so adding an effect is its module
    and its name here, nothing else)."""
    table = {}
    for module in modules:
        entry = import_module(f"{__package__}.{module}").ENTRY
        if entry.name in table or (len(entry.settings) != 1 and entry.parse is None):
            raise ValueError(f"effect {entry.name!r}: listed twice, or several settings and no parse")
        table[entry.name] = entry
    return table


ENTRIES: dict[str, EffectEntry] = _table(
    "weather",
)


def simple_entries() -> tuple[EffectEntry, ...]:
    """The effects of one setting (--NAME VALUE, SPEC.toml [effects] NAME, a panel field)."""
    return tuple(e for e in ENTRIES.values() if e.parse is None)


def user_effects(values: dict, sensor) -> tuple[Effect, ...]:
    """The effects `values` (entry name -> its value: a number, or weather's dict) turn on, in
    the table's order, made for `sensor`; a value of 0, {} or None is off (clear air)."""
    made = (ENTRIES[name].make(values[name], sensor) for name in ENTRIES if values.get(name))
    return tuple(e for e in made if e is not None)
