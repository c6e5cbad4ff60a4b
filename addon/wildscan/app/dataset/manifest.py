"""The manifest: one JSON row per scan (manifest.jsonl), kept by the client.

Rows arrive from the workers as their batches finish; after each batch the whole file is
written to a temporary name and renamed, so a reader (or a rerun) only ever sees a
complete manifest, sorted by (sequence, scan). `seconds` is the only field that differs
between runs; everything else is a function of the spec.
"""

from __future__ import annotations

import hashlib
import json
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ...core.errors import UserError
from ...core.io.files import atomic_outputs, write_durably
from .layout import MANIFEST

_HASH_CHUNK = 1 << 20


class Manifest:
    def __init__(self, root: Path, rows: dict[tuple[str, int], dict] | None = None):
        self.root = Path(root)
        self.rows: dict[tuple[str, int], dict] = {}
        self._lines: dict[tuple[str, int], str] = {}
        for row in (rows or {}).values():
            self.add(row)

    @property
    def path(self) -> Path:
        return self.root / MANIFEST

    @classmethod
    def load(cls, root: Path) -> "Manifest":
        manifest = cls(root)
        if not manifest.path.exists():
            return manifest
        try:
            text = manifest.path.read_text(encoding="utf-8")
        except OSError as e:
            raise UserError(f"cannot read {manifest.path}: {e.strerror or e}") from None
        for number, line in enumerate(text.splitlines(), 1):
            try:
                manifest.add(json.loads(line))
            except (ValueError, KeyError, TypeError):
                raise UserError(f"{manifest.path} line {number} is not a manifest row") from None
        return manifest

    def add(self, row: dict) -> None:
        key = (row["sequence"], int(row["scan"]))
        self.rows[key] = row
        self._lines[key] = json.dumps(row, sort_keys=True, separators=(",", ":"))

    def drop(self, key: tuple[str, int]) -> None:
        self.rows.pop(key, None)
        self._lines.pop(key, None)

    def write(self) -> None:
        data = "".join(self._lines[k] + "\n" for k in sorted(self._lines)).encode("utf-8")
        with atomic_outputs(self.path) as (tmp,):
            write_durably(tmp, lambda f: f.write(data))

    def ok_rows(self) -> list[dict]:
        return [self.rows[k] for k in sorted(self.rows) if self.rows[k]["status"] == "ok"]


def file_problem(root: Path, record: dict) -> str | None:
    """Why a file does not match its record (missing, size, SHA-256), or None."""
    path = root / record["path"]
    try:
        size = path.stat().st_size
        if size != record["bytes"]:
            return f"{record['path']}: {size:,} bytes, the manifest says {record['bytes']:,}"
        digest = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(_HASH_CHUNK), b""):
                digest.update(block)
    except OSError as e:
        return f"{record['path']}: {e.strerror or e}"
    if digest.hexdigest() != record["sha256"]:
        return f"{record['path']}: SHA-256 differs from the manifest (the file was changed)"
    return None


def check_files(root: Path, records: list[dict]) -> list[str | None]:
    """file_problem for every record, hashed in parallel threads (hashlib releases the GIL)."""
    with ThreadPoolExecutor(max_workers=max(1, min(8, os.cpu_count() or 1))) as pool:
        return list(pool.map(lambda r: file_problem(root, r), records))


def broken_rows(manifest: Manifest) -> dict[tuple[str, int], str]:
    """The ok rows whose files no longer match (key -> first problem)."""
    keys, records = [], []
    for key, row in manifest.rows.items():
        if row["status"] == "ok":
            for record in row["files"]:
                keys.append(key)
                records.append(record)
    out: dict[tuple[str, int], str] = {}
    for key, problem in zip(keys, check_files(manifest.root, records), strict=True):
        if problem and key not in out:
            out[key] = problem
    return out
