"""The labeled point cloud a scan produces, as plain numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .classes import colors_of

# PLY vertex fields in file order (docs/architecture.md "Files") and their numpy types.
# `scalar_label` repeats `label` because CloudCompare's command-line mode only
# loads `intensity` and properties named `scalar_*` as scalar fields.
PLY_FIELDS: tuple[tuple[str, str], ...] = (
    ("x", "<f4"),
    ("y", "<f4"),
    ("z", "<f4"),
    ("intensity", "<f4"),
    ("label", "<u4"),
    ("instance", "<u4"),
    ("red", "u1"),
    ("green", "u1"),
    ("blue", "u1"),
    ("ring", "<u2"),
    ("sweep", "<u2"),
    ("range", "<f4"),
    ("scalar_label", "<f4"),
)


@dataclass
class PointCloud:
    """One labeled 3D scan. All arrays have length N (one entry per point)."""

    xyz: np.ndarray  # float64 (N,3) metres, in the frame named by `frame`
    intensity: np.ndarray  # float32 (N,) reflectivity measured (Table I)
    label: np.ndarray  # uint16 (N,) class id (classes.CLASSES; 0 = unlabeled)
    instance: np.ndarray  # uint32 (N,) wildscan_instance of the element hit
    ring: np.ndarray  # uint16 (N,) beam index n inside the 2D scan (0..1079)
    sweep: np.ndarray  # uint16 (N,) 2D scan index m (0..M-1)
    range: np.ndarray  # float32 (N,) measured range in metres (noise included)
    frame: str = "leveled"

    def __len__(self) -> int:
        return len(self.label)

    @property
    def colors(self) -> np.ndarray:
        return colors_of(self.label)

    def to_structured(self) -> np.ndarray:
        """The PLY vertex records (PLY_FIELDS order, little-endian)."""
        out = np.empty(len(self), dtype=list(PLY_FIELDS))
        xyz = np.asarray(self.xyz, dtype=np.float32)
        out["x"], out["y"], out["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
        out["intensity"] = self.intensity
        out["label"] = self.label
        out["instance"] = self.instance
        rgb = self.colors
        out["red"], out["green"], out["blue"] = rgb[:, 0], rgb[:, 1], rgb[:, 2]
        out["ring"] = self.ring
        out["sweep"] = self.sweep
        out["range"] = self.range
        out["scalar_label"] = self.label
        return out

    def class_counts(self) -> dict[int, int]:
        ids, counts = np.unique(self.label, return_counts=True)
        return {int(i): int(c) for i, c in zip(ids, counts)}
