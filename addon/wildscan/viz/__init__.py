"""Pictures: the aerial map of a world, scan previews, the benchmark's chart (matplotlib).

matplotlib is an optional extra (`pip install wildscan[viz]`): every module here
imports it inside its functions, so importing them never needs it, and a command
that would draw says so in one line when it is missing (Blender's own Python, for
one, does not ship it).
"""

from __future__ import annotations

from ..core.errors import UserError


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def require_matplotlib(setting: str = "map") -> None:
    """UserError naming `setting` (the option that asked for a picture) without matplotlib."""
    if not have_matplotlib():
        raise UserError(
            "needs matplotlib (pip install matplotlib); it is not installed here", setting=setting
        )
