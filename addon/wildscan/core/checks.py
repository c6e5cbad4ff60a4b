"""Parsing what users type (numpy-free): one message style for every command."""

from __future__ import annotations

import re

from .errors import UserError

# ASCII digits only: str.isdigit() also accepts "²" and other digits int() refuses.
_WHOLE = re.compile(r"[0-9]{1,19}")


def whole_number(text, option: str, low: int, high: int) -> int:
    """`text` as an integer in [low, high], or UserError naming the option and the range."""
    s = str(text).strip()
    if isinstance(text, bool) or not _WHOLE.fullmatch(s) or not low <= int(s) <= high:
        raise UserError(f"{option} must be a whole number from {low} to {high}, got {text!r}")
    return int(s)
