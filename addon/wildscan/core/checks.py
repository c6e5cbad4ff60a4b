"""Parsing what users type (numpy-free): one message style for every front end."""

from __future__ import annotations

import json
import math
import re

from .errors import UserError, shortened

# ASCII digits only: str.isdigit() also accepts "²" and other digits int() refuses.
_WHOLE = re.compile(r"[0-9]{1,19}")
# A number as users type it (an option, --weather, a dust region, a waypoints file): ASCII
# digits, a point for decimals, an optional sign and exponent; inf and nan as words (for the
# caller to refuse by name). float() alone also takes "1_0", "٣" and full-width "１０".
# (Each part has one way to match: "[0-9]+\.?[0-9]*" took quadratic time on 100,000 digits.)
DECIMAL = re.compile(
    r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)(e[+-]?[0-9]+)?|[+-]?(inf|infinity|nan)", re.IGNORECASE
)


def decimal(text) -> float:
    """User text as a float by the one rule for typed numbers (DECIMAL), surrounding spaces
    ignored; ValueError for anything else. Every parser of numbers from text uses this."""
    s = str(text).strip()
    if not DECIMAL.fullmatch(s):
        raise ValueError(f"not a number of ASCII digits: {s!r}")
    return float(s)


def whole_number(text, setting: str, low: int, high: int) -> int:
    """`text` as an integer in [low, high], or UserError naming the setting and the range."""
    s = str(text).strip()
    if isinstance(text, bool) or not _WHOLE.fullmatch(s) or not low <= int(s) <= high:
        raise UserError(
            f"must be a whole number from {low} to {high}, got {text!r}", setting=setting, allowed=(low, high)
        )
    return int(s)


def one_of(value: str, setting: str, choices) -> str:
    """`value` when it is one of `choices`, or UserError naming the setting and the choices."""
    choices = tuple(choices)
    if value not in choices:
        raise UserError(
            f"must be one of {', '.join(choices)}, got {value!r}", setting=setting, allowed=choices
        )
    return value


# -- TOML tables (a dataset's SPEC.toml, a device file) -------------------------------------

REQUIRED = object()  # a key with no default: its absence is a mistake ("got nothing")


def is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def show(value) -> str:
    """A value from a file as a message quotes it: TOML's own spelling, shortened."""
    if value is None or value is REQUIRED:
        return "nothing"
    if isinstance(value, (str, list, dict, bool)):  # "²..³" as written, not escaped
        return shortened(value, text=json.dumps(value, ensure_ascii=False))
    return shortened(value, text=repr(value))


class Table:
    """One TOML table with its dotted name, for messages that say which key is wrong and what
    is allowed. Each reader takes the key, what is allowed, and a `default` for a key that may
    be left out (REQUIRED: it may not)."""

    def __init__(self, data: dict, prefix: str, where: str):
        self.data, self.prefix, self.where = data, prefix, where

    def name(self, key: str) -> str:
        return f"{self.prefix}{key}"

    def fail(self, key: str, allowed: str, value) -> UserError:
        return UserError(f"{self.where}: {self.name(key)} must be {allowed}, got {show(value)}")

    def only(self, *keys: str) -> None:
        for key in self.data:
            if key not in keys:
                where = f"[{self.prefix[:-1]}]" if self.prefix else "the top level"
                raise UserError(
                    f"{self.where}: unknown key {self.name(key)!r}; allowed in {where}: {', '.join(keys)}"
                )

    def get(self, key: str, default=None):
        return self.data.get(key, default)

    def table(self, key: str, default=REQUIRED) -> "Table":
        value = self.data.get(key, default)
        if not isinstance(value, dict):
            raise self.fail(key, "a table", value)
        return Table(value, f"{self.name(key)}.", self.where)

    def text(self, key: str, default=REQUIRED) -> str:
        value = self.data.get(key, default)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, "a name in quotes", value)
        return value

    def choice(self, key: str, allowed: tuple[str, ...], default=REQUIRED) -> str:
        value = self.data.get(key, default)
        if value not in allowed:
            raise self.fail(key, "one of " + ", ".join(f'"{a}"' for a in allowed), value)
        return value

    def integer(self, key: str, low: int, high: int, default=REQUIRED) -> int:
        value = self.data.get(key, default)
        if not is_int(value) or not low <= value <= high:
            raise self.fail(key, f"a whole number from {low} to {high}", value)
        return value

    def number(self, key: str, low: float, high: float, low_open: bool = False, default=REQUIRED) -> float:
        value = self.data.get(key, default)
        if not is_number(value) or not (low < value if low_open else low <= value) or value > high:
            bound = "above" if low_open else "from"
            raise self.fail(
                key, f"a number {bound} {low:g} {'and at most' if low_open else 'to'} {high:g}", value
            )
        return float(value)

    def numbers(self, key: str, low: float, high: float, least: int, most: int) -> tuple[float, ...]:
        value = self.data.get(key)
        count = f"{least}" if least == most else f"{least} to {most}"
        if (
            not isinstance(value, list)
            or not least <= len(value) <= most
            or not all(is_number(v) and low <= v <= high for v in value)
        ):
            raise self.fail(key, f"a list of {count} numbers from {low:g} to {high:g}", value)
        return tuple(float(v) for v in value)

    def integers(self, key: str, low: int, high: int, least: int, most: int) -> tuple[int, ...]:
        value = self.data.get(key)
        allowed = f"a list of {least} whole numbers from {low} to {high}"
        if not isinstance(value, list) or not least <= len(value) <= most:
            raise self.fail(key, allowed, value)
        if not all(is_int(v) and low <= v <= high for v in value):
            raise self.fail(key, allowed, value)
        return tuple(value)
