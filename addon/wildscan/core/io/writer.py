"""What a format writer is (numpy only): the record every format module gives the table in
formats.py, and the scan it encodes.

A writer turns one scan into the bytes of its files, by kind ("ply", "ply_sidecar",
"velodyne", ...); it never touches the disk. Its caller says where the files go (a single
scan: --out and names beside it, formats.py; a dataset: its sequence folders; a drive: its
raw/ and deskewed/ folders) and writes them together, all or none.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..label_schemes import LabelScheme
from ..pointcloud import PointCloud


@dataclass(frozen=True)
class ScanFile:
    """One file a format writes per scan."""

    kind: str  # its key in the paths a writer gets and in the bytes it returns
    suffix: str  # ".bin", with the dot
    folder: str  # in a dataset: sequences/NN/<folder>/NNNNNN<suffix>
    ground_truth: bool = False  # written only with ScanOutput.hag (datasets): not for a single scan


@dataclass(frozen=True)
class ScanOutput:
    """One scan as every writer takes it."""

    cloud: PointCloud
    metadata: dict  # the scan's metadata (core/scan.py run_scan), with what the caller adds
    labels: LabelScheme  # the ids of label files (SemanticKITTI .label, LAS `label`); a PLY's are WildScan's
    # every instance id of the world (SemanticKITTI ranks them); None: rank the scan's own
    world_instances: np.ndarray | None = None
    hag: np.ndarray | None = None  # height above the standing ground per point, where known (datasets)
    ascii: bool = False  # PLY only: ASCII instead of binary little-endian
    # uint8 per point: on the surface the robot rests on (core/traversability.py), where known
    # (datasets; PLY writes it, other formats carry label and hag it follows from)
    support: np.ndarray | None = None
    # (rows, columns) of the range-image cells whose return the realistic model's detection step
    # dropped (core/scan.py ScanResult.lost_cells): the range image's `lost` mask; None: none
    lost_cells: tuple[np.ndarray, np.ndarray] | None = None


@dataclass(frozen=True)
class Writer:
    """A format: its name (--format NAME, a dataset's `formats`), its title (the add-on's
    export menu), what it writes, its files per scan (the first is the one --out names, the
    others go beside it with their own suffixes), the label ids a single scan in it carries,
    and `encode(scan, paths) -> {kind: bytes}` (paths: kind -> where each file goes, which a
    file may mention, as a PLY's sidecar does)."""

    name: str
    title: str
    writes: str
    files: tuple[ScanFile, ...]
    scan_labels: str  # the label scheme (core/label_schemes.py) of `wildscan scan --format NAME`
    encode: Callable[[ScanOutput, dict[str, Path]], dict[str, bytes]]
    ascii: bool = False  # whether it has an ASCII form (--ascii)

    @property
    def suffix(self) -> str:
        return self.files[0].suffix

    @property
    def scan_files(self) -> tuple[ScanFile, ...]:
        """The files of a single scan (no ground truth): distinct suffixes, checked in formats.py."""
        return tuple(f for f in self.files if not f.ground_truth)
