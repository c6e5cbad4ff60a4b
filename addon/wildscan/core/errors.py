"""Errors a user can cause and fix: commands print the message as one line and exit 2.

The core never spells a command-line option or a panel label: an error names the
setting at fault by its library name (`max_range`, `seed`) and says what is wrong in
words that follow that name. Each front end phrases it with its own name for the
setting (app/settings.py: `--max-range` on the command line, "Max range" in the panel).
"""

from __future__ import annotations

from collections.abc import Callable


class UserError(Exception):
    """A mistake in what the user asked for (bad value, rejected pose, unreadable file).

    message   what is wrong; with a `setting`, worded to follow its name:
              UserError("must be in (0, 30] m, got 31", setting="max_range")
    setting   the library name of the setting at fault, or None when the message
              stands alone ("cannot write scan.ply: disk full")
    allowed   the values the setting accepts, for a front end that wants them: a tuple
              of names, or (low, high) bounds (None for an open side)
    related   other settings the message names, written as {name} fields in it:
              UserError("(5 m) must be below {max_range} (4 m)", setting="min_range",
              related=("max_range",))
    """

    def __init__(
        self,
        message: str,
        setting: str | None = None,
        allowed: tuple | None = None,
        related: tuple[str, ...] = (),
    ):
        super().__init__(message)
        self.message = message
        self.setting = setting
        self.allowed = allowed
        self.related = tuple(related)

    def __reduce__(self):  # keep every field across pickling (worker processes)
        return type(self), (self.message, self.setting, self.allowed, self.related)

    def phrase(self, name_of: Callable[[str], str]) -> str:
        """The message with every setting it names called `name_of(setting)`."""
        text = self.message
        if self.related:
            text = text.format_map({name: name_of(name) for name in self.related})
        return f"{name_of(self.setting)} {text}" if self.setting else text

    def __str__(self) -> str:
        """Phrased with the library's own names (`max_range must be ...`)."""
        return self.phrase(str)


QUOTED_CHARS = 80  # the most of one user value an error message quotes


def shortened(value, limit: int = QUOTED_CHARS, text: str | None = None) -> str:
    """A user's value as a one-line message quotes it (`text`, its spelling, default str):
    whole when short, else its start and end around an ellipsis, with its size (a
    100,000-beam list is not a line)."""
    text = str(value) if text is None else text
    if len(text) <= limit:
        return text
    head = limit * 2 // 3
    size = f"{len(value):,} values" if isinstance(value, (list, tuple)) else f"{len(text):,} characters"
    return f"{text[:head]}…{text[head - limit + 1 :]} ({size})"


class PoseRejected(UserError):
    """The placement lasers say the structure cannot stand at this pose."""
