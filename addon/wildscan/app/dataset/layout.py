"""Where everything of a dataset lives inside its output folder (docs/datasets.md)."""

from __future__ import annotations

import os
import re
from pathlib import Path

from ...core.io.formats import WRITERS

MANIFEST = "manifest.jsonl"
DATASET_JSON = "dataset.json"
CARD = "CARD.md"
CARD_FIGURES = "card"
LABELS_YAML = "labels.yaml"
WEIGHTS_JSON = "weights.json"  # class weights over the learning map (core/class_weights.py)
LOCK = ".wildscan-dataset.lock"
# core.io.files.temp_path names temporary files ".NAME.tmp-PID.EXT"
TEMP_NAME = re.compile(r"^\..+\.tmp-\d+(\.[A-Za-z0-9]+)?$")

# format -> (kind, folder, suffix) of its per-scan files (core/io/formats.py), and the
# bird's-eye grid every scan has
SCAN_FILES: dict[str, tuple[tuple[str, str, str], ...]] = {
    **{name: tuple((f.kind, f.folder, f.suffix) for f in w.files) for name, w in WRITERS.items()},
    "bev": (("bev", "bev", ".npy"),),
}


def sequence_dir(sequence: str) -> str:
    return f"sequences/{sequence}"


def scan_paths(formats, sequence: str, index: int) -> dict[str, str]:
    """kind -> path relative to the output folder of every file of one scan; `index` is its
    file number (dense over the scans with a pose: worker.WorldContext.file_numbers)."""
    out = {}
    for fmt in (*formats, "bev"):
        for kind, folder, suffix in SCAN_FILES[fmt]:
            out[kind] = f"{sequence_dir(sequence)}/{folder}/{index:06d}{suffix}"
    return out


def sequence_files(sequence: str) -> dict[str, str]:
    return {"poses": f"{sequence_dir(sequence)}/poses.txt", "calib": f"{sequence_dir(sequence)}/calib.txt"}


def remove_temp_files(root: Path) -> int:
    """Delete temporary files a killed run left (only while holding the run's lock)."""
    removed = 0
    for folder, _, names in os.walk(root):
        for name in names:
            if TEMP_NAME.match(name):
                try:
                    os.unlink(os.path.join(folder, name))
                    removed += 1
                except OSError:
                    pass
    return removed
