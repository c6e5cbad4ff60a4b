"""Parsing what users type (numpy-free): one message style for every front end."""

from __future__ import annotations

import re

from .errors import UserError

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
