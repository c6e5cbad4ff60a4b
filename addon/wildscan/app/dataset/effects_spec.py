"""SPEC.toml's effects (core/effects/table.py): `[weather]` (each key of core/effects/weather.py
a value or a range [lo, hi] drawn per scan) and `[effects]` (each effect of one setting, NAME =
a value or a range [lo, hi]), checked with the limits the table declares."""

from __future__ import annotations

from ...core.errors import UserError

Value = float | tuple[float, float]


def weather_table(t) -> tuple[tuple[str, Value], ...]:
    """[weather]: each key of core/effects/weather.py a value or a range [lo, hi] of values."""
    from ...core.effects.weather import KEYS, check_value

    return _ranged(t, KEYS, check_value)


def effects_table(t) -> tuple[tuple[str, Value], ...]:
    """[effects]: each effect of one setting of the effects table, a value or a range [lo, hi]."""
    from ...core.effects.table import simple_entries

    entries = {e.name: e.settings[0] for e in simple_entries()}
    return _ranged(t, entries, lambda name, v: entries[name].check(v, name))


def _ranged(t, keys, check) -> tuple[tuple[str, Value], ...]:
    t.only(*keys)
    out = []
    for key in keys:
        value = t.get(key, None)
        if value is None:
            continue
        bounds = value if isinstance(value, list) else [value]
        try:
            if len(bounds) not in (1, 2) or any(isinstance(v, (list, dict, str)) for v in bounds):
                raise UserError("a number or a range [lo, hi]")
            checked = [check(key, v) for v in bounds]
        except UserError as e:
            raise UserError(f"{t.where}: {t.name(key)}: {e.message}") from None
        if len(checked) == 2 and checked[0] > checked[1]:
            raise t.fail(key, "a range [lo, hi] with lo <= hi", value)
        out.append((key, (checked[0], checked[1]) if len(checked) == 2 else checked[0]))
    return tuple(out)
