"""Scans named in a message: runs of numbers joined, sequence by sequence (a stopped run's
line says which scans it completed)."""

from __future__ import annotations

SEQUENCES_NAMED = 3  # in a stop message; the rest are counted


def scan_names(keys: list[tuple[str, int]]) -> str:
    """ "sequence 00 scans 0-3 and 5, sequence 01 scan 2": the scans by sequence, runs of
    numbers joined, the first SEQUENCES_NAMED sequences named and the rest counted."""
    by_sequence: dict[str, list[int]] = {}
    for seq, scan in sorted(set(keys)):
        by_sequence.setdefault(seq, []).append(scan)
    parts = [
        f"sequence {seq} {_numbers(scans)}" for seq, scans in list(by_sequence.items())[:SEQUENCES_NAMED]
    ]
    rest = sum(len(s) for s in list(by_sequence.values())[SEQUENCES_NAMED:])
    if rest:
        more = len(by_sequence) - SEQUENCES_NAMED
        parts.append(f"{rest:,} more in {more:,} more sequence{'s' if more > 1 else ''}")
    return ", ".join(parts)


def _numbers(scans: list[int]) -> str:
    runs: list[list[int]] = []
    for n in scans:
        if runs and n == runs[-1][-1] + 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    words = [f"{r[0]}-{r[-1]}" if len(r) > 1 else f"{r[0]}" for r in runs]
    joined = ", ".join(words[:-1]) + f" and {words[-1]}" if len(words) > 1 else words[0]
    return f"scan{'s' if len(scans) > 1 else ''} {joined}"
