"""How operators talk to the user: progress on the window manager and one-line reports of
bugs. (User errors are phrased for the panel by app.settings.panel_message.)"""

from __future__ import annotations

import sys
import traceback

PROGRESS_STEPS = 1000
STAGE_HALF = 4  # world-building stages after which the bar shows half way


def tag_view3d_redraw(context) -> None:
    for window in context.window_manager.windows:
        screen = window.screen
        for area in screen.areas if screen is not None else ():
            if area.type in {"VIEW_3D", "PROPERTIES"}:
                area.tag_redraw()


def internal_error(operator, what: str, error: BaseException) -> set:
    """Report a bug as one line in Blender (the traceback goes to the system console only,
    for a bug report) and cancel."""
    sys.stderr.write(f"WildScan: unexpected error while {what} (please report it):\n")
    traceback.print_exception(type(error), error, error.__traceback__, file=sys.stderr)
    operator.report({"ERROR"}, f"WildScan could not finish {what}: {type(error).__name__}: {error}")
    return {"CANCELLED"}


class Progress:
    """window_manager.progress_begin/update/end plus a status-bar line, as a context manager.

    `scan(done, total)` fits wildscan.core.scan's progress callback and
    `stage(text, fraction)` the world generator's."""

    def __init__(self, context, label: str):
        self.wm = context.window_manager
        self.workspace = getattr(context, "workspace", None) if getattr(context, "window", None) else None
        self.label = label
        self.stages = 0

    def __enter__(self) -> "Progress":
        self.wm.progress_begin(0, PROGRESS_STEPS)
        self._status(self.label)
        return self

    def __exit__(self, *exc) -> None:
        self.wm.progress_end()
        self._status(None)

    def fraction(self, value: float, text: str | None = None) -> None:
        value = min(max(float(value), 0.0), 1.0)
        self.wm.progress_update(int(round(value * PROGRESS_STEPS)))
        self._status(f"{self.label}: {text + ' ' if text else ''}{100 * value:.0f}%")

    def scan(self, done: int, total: int) -> None:
        self.fraction(done / total if total else 1.0, f"{done:,}/{total:,} beams")

    def stage(self, text: str, _value: float = 0.0) -> None:
        """One finished stage of the world builder. Its number is the builder's own (seconds
        spent, or a fraction), so the bar advances by stages instead: k stages done shows
        k/(k+STAGE_HALF), always moving, never reaching the end before the build does."""
        self.stages += 1
        self.fraction(self.stages / (self.stages + STAGE_HALF), str(text))

    def _status(self, text: str | None) -> None:
        if self.workspace is not None:
            try:
                self.workspace.status_text_set(text)
            except (AttributeError, RuntimeError, TypeError):
                self.workspace = None  # no status bar here (background mode)
