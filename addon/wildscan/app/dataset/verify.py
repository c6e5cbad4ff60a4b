"""`wildscan dataset --verify DIR`: the folder against its spec, not only against its manifest.

Four checks: every file the manifest and dataset.json list is there with its size and
SHA-256; the manifest has a row for every scan the spec plans (seeds x scans_per_world) and
none it does not; a dataset that says it is complete has its card; and every file in the
folder is listed somewhere (a stray scan file, or a temporary file a stopped run left, is
named: a loader that globs the folder would read it).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from ...core.errors import UserError
from ...core.io.files import user_path
from . import card
from .layout import CARD, CARD_FIGURES, DATASET_JSON, LOCK, MANIFEST, TEMP_NAME
from .lock import refuse_while_written
from .manifest import Manifest, check_files

MISSING_SHOWN = 3  # missing scans named in the line that counts them


@dataclass
class VerifyReport:
    root: Path
    checked: int  # files compared with their size and SHA-256
    problems: list[str]  # every problem, one line each
    scans: int  # manifest rows of planned scans
    planned: int
    complete: bool  # complete by every check (not only by what dataset.json says)
    file_problems: int = 0  # files that differ from (or are missing against) their record
    unlisted: list[str] = field(default_factory=list)


def verify_dataset(out) -> VerifyReport:
    root = user_path(out, "verify", "a directory name")
    refuse_while_written(root, "verify")
    data = card.read_dataset_json(root) if root.is_dir() else None
    if data is None:
        raise UserError(f"--verify {root}: no WildScan dataset there (no dataset.json)")
    manifest = Manifest.load(root)
    records = [f for row in manifest.ok_rows() for f in row["files"]] + list(data.get("files", {}).values())
    file_problems = [p for p in check_files(root, records) if p]
    planned_keys = _planned_keys(data["spec"])
    rows = _row_problems(manifest, planned_keys) + _hash_problems(manifest, data["config_hash"])
    says_complete = bool(data.get("complete"))
    missing = [k for k in planned_keys if k not in manifest.rows]
    card_problems = _card_problems(root, says_complete)
    if says_complete and missing:
        rows.insert(0, _missing_line(missing, len(planned_keys)))
    unlisted = unlisted_files(root, {r["path"] for r in records})
    problems = (
        file_problems + rows + card_problems + [_unlisted_line(root, rel, says_complete) for rel in unlisted]
    )
    scans = sum(1 for k in manifest.rows if k in planned_keys)
    complete = says_complete and not problems  # a problem of any kind: not a complete dataset
    return VerifyReport(
        root, len(records), problems, scans, len(planned_keys), complete, len(file_problems), unlisted
    )


def _planned_keys(spec: dict) -> set[tuple[str, int]]:
    """(sequence, scan) of every scan the spec plans: sequence NN is the seed's position."""
    return {(f"{k:02d}", i) for k in range(len(spec["seeds"])) for i in range(spec["scans_per_world"])}


def _row_problems(manifest: Manifest, planned: set[tuple[str, int]]) -> list[str]:
    return [
        f"{MANIFEST}: a row for scan {scan} of sequence {seq}, which the spec does not plan"
        for seq, scan in sorted(manifest.rows)
        if (seq, scan) not in planned
    ]


def _hash_problems(manifest: Manifest, wanted: str) -> list[str]:
    """Rows made under another config (a device file edited while a run was writing): one
    line counting them, naming the first."""
    rows = sorted(manifest.rows.items())
    other = [key for key, row in rows if row["config_hash"] != wanted]
    if not other:
        return []
    seq, scan = other[0]
    return [
        f"{MANIFEST}: {len(other):,} scans (the first: scan {scan} of sequence {seq}) were made under "
        f"another config than {DATASET_JSON}'s (hash {wanted[:12]}): an edited device file? The same "
        "command refuses to continue until the spec and its files are as the dataset began"
    ]


def _missing_line(missing: list[tuple[str, int]], planned: int) -> str:
    shown = ", ".join(f"scan {scan} of sequence {seq}" for seq, scan in sorted(missing)[:MISSING_SHOWN])
    more = f" and {len(missing) - MISSING_SHOWN:,} more" if len(missing) > MISSING_SHOWN else ""
    return (
        f"{DATASET_JSON} says complete but {MANIFEST} has no row for {len(missing):,} of the {planned:,} "
        f"planned scans ({shown}{more})"
    )


def _card_problems(root: Path, says_complete: bool) -> list[str]:
    if says_complete and not (root / CARD).is_file():
        return [f"{CARD}: missing ({DATASET_JSON} says complete; the same command writes it)"]
    return []


def unlisted_files(root: Path, listed: set[str]) -> list[str]:
    """Files in the folder that neither the manifest nor dataset.json lists (relative paths,
    sorted); the card, its figures and the run's own files are known by name."""
    known = {MANIFEST, DATASET_JSON, CARD, LOCK}
    out = []
    for folder, dirs, names in os.walk(root):
        dirs.sort()
        for name in sorted(names):
            rel = (Path(folder) / name).relative_to(root).as_posix()
            if rel in listed or rel in known or rel.startswith(f"{CARD_FIGURES}/"):
                continue
            out.append(rel)
    return out


def _unlisted_line(root: Path, rel: str, says_complete: bool) -> str:
    if TEMP_NAME.match(Path(rel).name):
        return f"{rel}: a temporary file a stopped run left (the next run into {root} removes it)"
    line = f"{rel}: a file neither {MANIFEST} nor {DATASET_JSON} lists"
    if not says_complete and rel.startswith("sequences/"):  # a batch cut short by a kill
        line += " (a stopped run may have written it without recording it: the next run writes it again)"
    return line
