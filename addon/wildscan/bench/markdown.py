"""`wildscan bench --markdown FILE`: what a suite printed, written into a markdown page with
the facts a reader needs to weigh it (date, machine, WildScan version, the exact command).

Figures in the docs are never copied by hand: docs/benchmarks.md is made of these sections,
each one replaced in place when its suite runs again (the rest of the page is kept), so a
figure on the page is always the output of the command written above it.
"""

from __future__ import annotations

import contextlib
import io
import os
import platform
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path


def _command(suite: str) -> str:
    """The command a section comes from: a suite of `wildscan bench`, or a bench command of
    its own (`bench-dataset`)."""
    return f"wildscan {suite}" if suite.startswith("bench-") else f"wildscan bench --suite {suite}"


def begin_marker(suite: str) -> str:
    return f"<!-- begin {_command(suite)} (generated: rerun the command below, do not edit) -->"


def end_marker(suite: str) -> str:
    return f"<!-- end {_command(suite)} -->"


@dataclass(frozen=True)
class RunFacts:
    """What a reader needs to weigh a measurement."""

    command: str
    date: str
    machine: str
    version: str


def cpu_model() -> str:
    """The CPU's name from /proc/cpuinfo (Linux), else what the platform module says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("model name", "Hardware", "Processor") and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def machine_line() -> str:
    """Cores, CPU and the load when the run started: a loaded machine gives slower times,
    and the page says so rather than leaving the reader to guess."""
    cores = os.cpu_count() or 0
    try:
        load = f", load average {os.getloadavg()[0]:.2f} at the start"
    except OSError:
        load = ""
    return f"{cores} cores, {cpu_model()}, {platform.system()} {platform.machine()}{load}"


def run_facts(command: str) -> RunFacts:
    from .. import __version__

    date = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return RunFacts(command=command, date=date, machine=machine_line(), version=__version__)


class _Tee(io.TextIOBase):
    """Writes to the terminal and keeps a copy."""

    def __init__(self, terminal):
        self.terminal = terminal
        self.copy = io.StringIO()

    def write(self, text: str) -> int:
        self.terminal.write(text)
        self.copy.write(text)
        return len(text)

    def flush(self) -> None:
        self.terminal.flush()


@contextlib.contextmanager
def printed_copy() -> Iterator[io.StringIO]:
    """Inside the block everything printed still reaches the terminal; the yielded buffer
    holds a copy once the block ends."""
    tee = _Tee(sys.stdout)
    with contextlib.redirect_stdout(tee):
        yield tee.copy


def section_text(suite: str, facts: RunFacts, printed: str) -> str:
    """The marked section of one suite: its facts, then its output as printed."""
    body = printed.rstrip("\n").replace("```", "'''")
    return "\n".join(
        [
            begin_marker(suite),
            f"- Command: `{facts.command}`",
            f"- Date: {facts.date}",
            f"- Machine: {facts.machine}",
            f"- WildScan version: {facts.version}",
            "",
            "```text",
            body,
            "```",
            end_marker(suite),
        ]
    )


def replace_section(page: str, suite: str, section: str) -> str:
    """`page` with the suite's marked section replaced by `section` (appended when absent)."""
    begin, end = begin_marker(suite), end_marker(suite)
    start = page.find(begin)
    stop = page.find(end, start + 1) if start >= 0 else -1
    if start >= 0 and stop >= 0:
        return page[:start] + section + page[stop + len(end) :]
    if not page:
        return section + "\n"
    return page.rstrip("\n") + "\n\n" + section + "\n"


def write_markdown(path: Path, suite: str, facts: RunFacts, printed: str) -> Path:
    """Write the suite's section into `path` (created, or its section replaced), whole or
    not at all."""
    from ..core.io.files import atomic_outputs

    page = path.read_text(encoding="utf-8") if path.exists() else ""
    text = replace_section(page, suite, section_text(suite, facts, printed))
    with atomic_outputs(path) as (tmp,):
        tmp.write_text(text, encoding="utf-8")
    return path
