"""Waypoints of a drive from a CSV file (numpy only): one `x,y` a line, metres in the world
frame. Blank lines and lines starting with `#` are skipped, and so is a first line `x,y`
(a header). Anything else is a mistake, named by its line."""

from __future__ import annotations

import math
import os
import re

import numpy as np

from ..checks import decimal
from ..errors import UserError
from ..placement import MAX_COORDINATE
from .files import user_path

_HEADER = re.compile(r"\s*x\s*,\s*y\s*", re.IGNORECASE)
MAX_WAYPOINTS = 1_000_000


def read_waypoints(path: str | os.PathLike, setting: str = "waypoints") -> np.ndarray:
    """(n, 2) float64 waypoints from the CSV file at `path`, or UserError naming the line."""
    file = user_path(path, setting)

    def fail(why: str) -> UserError:
        return UserError(f"{file}: {why}", setting=setting)

    if file.is_dir():
        raise fail("is a directory, not a CSV file")
    try:
        text = file.read_bytes().decode("utf-8-sig")
    except FileNotFoundError:
        raise fail("no such file") from None
    except UnicodeDecodeError:
        raise fail("is not a text file (not UTF-8)") from None
    except OSError as e:
        raise fail(f"cannot read it ({e.strerror or e})") from None
    points = []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#") or (number == 1 and _HEADER.fullmatch(stripped)):
            continue
        points.append(_point(stripped, number, fail))
        if len(points) > MAX_WAYPOINTS:
            raise fail(f"more than {MAX_WAYPOINTS:,} waypoints")
    if not points:
        raise fail("holds no waypoints (one `x,y` a line, metres)")
    return np.array(points, dtype=np.float64)


def _point(text: str, number: int, fail) -> tuple[float, float]:
    fields = [f.strip() for f in text.split(",")]
    shown = text if len(text) <= 60 else text[:57] + "..."
    if len(fields) != 2:
        raise fail(f"line {number}: expected `x,y` (two numbers in metres), got {shown!r}")
    try:
        x, y = decimal(fields[0]), decimal(fields[1])
    except ValueError:
        raise fail(f"line {number}: expected `x,y` (two numbers in metres), got {shown!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)) or max(abs(x), abs(y)) > MAX_COORDINATE:
        raise fail(
            f"line {number}: coordinates must be finite and within +-{MAX_COORDINATE:g} m, got {shown!r}"
        )
    return x, y
