"""A dataset's `revisits.json`: per sequence (one world), the pairs of scans within 3 m and
the count of scans beyond 25 m of each (core/truth/revisits.py, Wild-Places' radii), written
at finalize from the manifest's rows, so a resumed dataset and a clean one have the same
bytes. Scans of different worlds never pair: their coordinates are of different landscapes."""

from __future__ import annotations

import numpy as np

from ...core.truth.revisits import revisits, revisits_document, revisits_json

REVISITS_JSON = "revisits.json"
SCAN_IDS = (
    "file number: NNNNNN of the scan's files in sequences/SS/, its line of poses.txt; `manifest_scan` "
    "gives each file number's scan in manifest.jsonl (they differ only after a scan without a pose)"
)


def sequence_revisits(rows: list[dict]) -> dict:
    """One world's revisits from its manifest rows (in scan order): the scans written, by the
    optical centre of their placement."""
    ok = [r for r in rows if r["status"] == "ok"]
    xy = np.array([r["placement"]["optical_centre"][:2] for r in ok], dtype=np.float64).reshape(-1, 2)
    return {**revisits(xy), "manifest_scan": [int(r["scan"]) for r in ok]}


def revisits_text(worlds: dict[str, list[dict]]) -> str:
    """revisits.json of the complete worlds: sequence -> its manifest rows in scan order."""
    sequences = {seq: sequence_revisits(rows) for seq, rows in sorted(worlds.items())}
    return revisits_json(revisits_document(sequences, SCAN_IDS))
