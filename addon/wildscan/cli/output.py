"""What the commands print: progress on stderr, results on stdout.

stderr otherwise stays for the one line of a user mistake, so a script can read it.
"""

from __future__ import annotations

import sys


class Progress:
    """Progress on stderr: one updating line on a terminal, a few lines in a log."""

    def __init__(self, label: str, quiet: bool = False):
        self.label = label
        self.quiet = quiet
        self.tty = sys.stderr.isatty()
        self.last_tenth = -1

    def __call__(self, done: int, total: int) -> None:
        if self.quiet or total <= 0:
            return
        tenth = (10 * done) // total
        if self.tty:
            sys.stderr.write(f"\r{self.label}: {100 * done // total:3d}% ({done:,}/{total:,})")
            if done >= total:
                sys.stderr.write("\n")
        elif tenth > self.last_tenth:
            sys.stderr.write(f"{self.label}: {100 * done // total}% ({done:,}/{total:,})\n")
        self.last_tenth = tenth
        sys.stderr.flush()


class StageProgress:
    """One line per stage on stderr: 'world: terrain        0.241 s'."""

    def __init__(self, quiet: bool = False, stream=None):
        self.quiet = quiet
        self.stream = stream or sys.stderr

    def __call__(self, stage: str, seconds: float) -> None:
        if not self.quiet:
            self.stream.write(f"world: {stage:<16} {seconds:7.3f} s\n")
            self.stream.flush()


def say(args, text: str) -> None:
    """Print unless the command was asked to be --quiet."""
    if not getattr(args, "quiet", False):
        print(text, flush=True)


def print_class_counts(counts: dict[int, int]) -> None:
    from ..core.classes import BY_ID

    for class_id in sorted(counts):
        print(f"  {class_id:2d} {BY_ID[class_id].name:<11} {counts[class_id]:>9,}")


def print_echo_summary(echoes: dict, points: int) -> None:
    """The realistic model's echo counts: beams by how many echoes they returned, mixed points."""
    beams = echoes["beams_by_echoes"]
    total = sum(beams.values()) or 1
    shares = ", ".join(
        f"{k} echo{'es' if k != '1' else ''} {100 * n / total:.1f} %" for k, n in beams.items()
    )
    mixed = echoes["mixed_points"]
    print(
        f"beams with points: {shares}; mixed pixels {mixed:,} "
        f"({100 * mixed / max(points, 1):.1f} % of points)"
    )
    lost = echoes.get("lost_returns")
    if lost and lost["weighed"]:
        print(
            f"echoes lost below the detection limit: {lost['lost']:,} of {lost['weighed']:,} "
            f"({100 * lost['lost'] / lost['weighed']:.1f} %; by class, range and incidence in the sidecar)"
        )
