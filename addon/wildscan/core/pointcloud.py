"""The labeled point cloud a scan produces, as plain numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass, field

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

# Optional per-point fields, in file order after `scalar_label`: a cloud carries those it
# has in `PointCloud.extra`; without any, files are exactly the PLY_FIELDS contract.
OPTIONAL_FIELDS: tuple[tuple[str, str], ...] = (
    ("hag", "<f4"),  # height above the ground the robot stands on under the point, metres (datasets)
    ("support", "u1"),  # 1 on the surface the robot would rest on (core/traversability.py; datasets)
    # a device other than the default's (core/sensors): the firing (or 2D scan) of the point,
    # counted on over a head's device sweeps; `sweep` is that firing within one device sweep
    ("column", "<u4"),
    # when the point was measured, seconds after its 3D scan's first beam (drives; scans by a
    # device other than the default, from its firing timing)
    ("time", "<f8"),
    # the realistic sensor model's (core/echoes.py); a paper-model scan has none of them
    ("echo", "u1"),  # which echo of its beam the point is, 1 = nearest
    ("echoes", "u1"),  # how many echoes its beam returned, 1..3
    ("label_purity", "<f4"),  # share of the echo's energy from the labeled class, 0..1
    ("mixed", "u1"),  # 1 where the point lies on no single surface: a mixed pixel
    # a dual-return scan's (core/sensors/returns.py): 1 strongest, 2 last, 3 both (its beam's
    # strongest is its last), 4 second strongest
    ("return_type", "u1"),
    # scans in weather (core/effects/weather.py): the effect that made a particle point,
    # 1 fog, 2 rain, 3 dust, 4 snow; 0 for a surface's
    ("weather", "u1"),
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
    extra: dict[str, np.ndarray] = field(default_factory=dict)  # OPTIONAL_FIELDS name -> (N,) array

    def __len__(self) -> int:
        return len(self.label)

    @property
    def colors(self) -> np.ndarray:
        return colors_of(self.label)

    def fields(self) -> tuple[tuple[str, str], ...]:
        """PLY_FIELDS, then the OPTIONAL_FIELDS this cloud carries, in registry order."""
        unknown = set(self.extra) - {name for name, _ in OPTIONAL_FIELDS}
        if unknown:
            raise ValueError(f"unknown optional point fields {sorted(unknown)}; see OPTIONAL_FIELDS")
        return PLY_FIELDS + tuple((name, code) for name, code in OPTIONAL_FIELDS if name in self.extra)

    def to_structured(self) -> np.ndarray:
        """The PLY vertex records (`fields()` order, little-endian)."""
        out = np.empty(len(self), dtype=list(self.fields()))
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
        for name in self.extra:
            out[name] = self.extra[name]
        return out

    def class_counts(self) -> dict[int, int]:
        """Points per class id, in id order (unsigned labels, a scan's: by a bincount, no sort)."""
        label = np.asarray(self.label)
        if label.dtype.kind != "u" or not len(label):
            ids, counts = np.unique(label, return_counts=True)
            return {int(i): int(c) for i, c in zip(ids, counts)}
        counts = np.bincount(label.astype(np.intp))
        return {int(i): int(counts[i]) for i in np.flatnonzero(counts)}
