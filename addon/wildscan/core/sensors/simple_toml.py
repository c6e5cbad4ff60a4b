"""The plain TOML of device files, for a Python with neither tomllib (3.11+) nor tomli
(numpy only). Blender 3.4 to 4.0 bundle Python 3.10 without tomli, and the add-on must still
read its presets there.

It reads what the presets use: comments, [table] headers, and one `key = value` a line whose
value is a "string", a number, or a one-line array of those (arrays nest). Anything else is
a TOMLDecodeError that says to install tomli, never a silent misreading.
"""

from __future__ import annotations

import ast
import re

from ..errors import shortened

_KEY = re.compile(r"[A-Za-z0-9_-]+")


class TOMLDecodeError(ValueError):
    pass


def loads(text: str) -> dict:
    data: dict = {}
    table = data
    for number, raw in enumerate(text.splitlines(), 1):
        line = _without_comment(raw).strip()
        if not line:
            continue
        if line.startswith("[") and line.endswith("]") and not line.startswith("[["):
            table = data.setdefault(_key(line[1:-1].strip(), number), {})
            continue
        key, sep, value = line.partition("=")
        if not sep:
            raise _error(number, "expected key = value")
        table[_key(key.strip(), number)] = _value(value.strip(), number)
    return data


def _without_comment(line: str) -> str:
    quoted = False
    for i, ch in enumerate(line):
        if ch == '"':
            quoted = not quoted
        elif ch == "#" and not quoted:
            return line[:i]
    return line


def _key(key: str, number: int) -> str:
    if not _KEY.fullmatch(key):
        raise _error(number, f"a key this reader does not know: {shortened(repr(key))}")
    return key


def _value(text: str, number: int):
    try:
        value = ast.literal_eval(text)
    except (ValueError, SyntaxError):
        raise _error(number, f"a value this reader does not know: {shortened(repr(text))}") from None
    if not _plain(value):
        raise _error(number, f"a value this reader does not know: {shortened(repr(text))}")
    return value


def _plain(value) -> bool:
    if isinstance(value, list):
        return all(_plain(v) for v in value)
    return isinstance(value, (str, int, float)) and not isinstance(value, bool)


def _error(number: int, what: str) -> TOMLDecodeError:
    return TOMLDecodeError(f"line {number}: {what} (install tomli for full TOML on Python 3.10)")
