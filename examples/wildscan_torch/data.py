"""The data path of the example, numpy and PyYAML only: a WildScan dataset's SemanticKITTI
files, their learning map and class weights (labels.yaml), and the spherical projection of
each scan into a range image, as RangeNet++ does it (Milioto et al., "RangeNet++: Fast and
Accurate LiDAR Semantic Segmentation", IROS 2019, Sec. III-A; semantic-kitti-api's
laserscan.py `do_range_projection`).

    u = ½ (1 − atan2(y, x) / π) · W           column from the azimuth
    v = (1 − (asin(z / r) − fov_down) / fov) · H   row from the elevation (row 0 the top)

Each pixel keeps its nearest point (points written far to near, so the nearest wins).
The UTM-30LX-EW on its rotating structure sees from straight up to about 45° below the
horizon (the 90° blind cone around −Z), hence the default field of view +90° .. −50°.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

FOV_UP_DEG = 90.0
FOV_DOWN_DEG = -50.0
HEIGHT = 64
WIDTH = 512
# channels of the image: range and x y z (and remission when asked), scaled to about [-1, 1]
RANGE_SCALE = 30.0  # m: the UTM-30LX-EW's maximum range
CHANNELS = ("range", "x", "y", "z")


@dataclass(frozen=True)
class LabelConfig:
    """What labels.yaml says a trainer needs."""

    learning_map: dict[int, int]  # raw label id -> learning id
    names: dict[int, str]  # learning id -> name
    ignore: frozenset[int]  # learning ids a loss leaves out (0: unlabeled)
    weights: dict[int, float]  # learning id -> class weight (0 for ignored / absent classes)
    split: dict[str, list[int]]  # train / valid / test -> sequence numbers

    @property
    def classes(self) -> int:
        return max(self.names) + 1

    def lookup(self) -> np.ndarray:
        """raw id -> learning id, as a table (raw ids fit 16 bits)."""
        table = np.zeros(max(self.learning_map) + 1, dtype=np.int64)
        for raw, xid in self.learning_map.items():
            table[raw] = xid
        return table

    def weight_vector(self) -> np.ndarray:
        """Per learning class its weight; 1 for every class a loss keeps when labels.yaml has
        none (a dataset made before WildScan wrote class weights)."""
        if not self.weights:
            return np.array([0.0 if k in self.ignore else 1.0 for k in range(self.classes)], dtype=np.float32)
        return np.array([self.weights.get(k, 0.0) for k in range(self.classes)], dtype=np.float32)


def load_label_config(root: Path, weights: str = "enet") -> LabelConfig:
    """labels.yaml of the dataset at `root`; `weights`: "enet" or "inverse_frequency"."""
    import yaml

    config = yaml.safe_load((Path(root) / "labels.yaml").read_text(encoding="utf-8"))
    inverse = config["learning_map_inv"]
    return LabelConfig(
        learning_map={int(k): int(v) for k, v in config["learning_map"].items()},
        names={int(x): config["labels"][raw] for x, raw in inverse.items()},
        ignore=frozenset(int(k) for k, v in config["learning_ignore"].items() if v),
        weights={int(k): float(v) for k, v in config.get(f"class_weights_{weights}", {}).items()},
        split={k: list(v or []) for k, v in config["split"].items()},
    )


def scan_files(root: Path, sequences: list[int]) -> list[tuple[Path, Path]]:
    """(velodyne .bin, .label) of every scan of the sequences, in order."""
    out = []
    for seq in sequences:
        folder = Path(root) / "sequences" / f"{seq:02d}"
        for scan in sorted((folder / "velodyne").glob("*.bin")):
            out.append((scan, folder / "labels" / f"{scan.stem}.label"))
    return out


def read_scan(bin_path: Path, label_path: Path, config: LabelConfig):
    """(xyz float32 (N, 3), remission (N,), learning ids (N,)) of one scan."""
    points = np.fromfile(bin_path, dtype="<f4").reshape(-1, 4)
    raw = np.fromfile(label_path, dtype="<u4") & 0xFFFF
    if len(raw) != len(points):
        raise ValueError(f"{label_path}: {len(raw)} labels for {len(points)} points")
    return points[:, :3], points[:, 3], config.lookup()[raw]


@dataclass
class Projection:
    image: np.ndarray  # float32 (C, H, W), 0 where no point
    labels: np.ndarray  # int64 (H, W), learning ids, 0 (ignored) where no point
    mask: np.ndarray  # bool (H, W): a point is there
    row: np.ndarray  # int64 (N,) each point's pixel (for scoring points, not pixels)
    col: np.ndarray  # int64 (N,)


def pixel_of(
    xyz: np.ndarray, height: int = HEIGHT, width: int = WIDTH, fov_up=FOV_UP_DEG, fov_down=FOV_DOWN_DEG
):
    """(row, column) of each point: the spherical projection of the module docstring."""
    xyz = np.asarray(xyz, dtype=np.float64)
    r = np.maximum(np.linalg.norm(xyz, axis=1), 1e-9)
    yaw = np.arctan2(xyz[:, 1], xyz[:, 0])
    pitch = np.arcsin(np.clip(xyz[:, 2] / r, -1.0, 1.0))
    up, down = np.radians(fov_up), np.radians(fov_down)
    u = 0.5 * (1.0 - yaw / np.pi) * width
    v = (1.0 - (pitch - down) / (up - down)) * height
    col = np.clip(np.floor(u), 0, width - 1).astype(np.int64)
    row = np.clip(np.floor(v), 0, height - 1).astype(np.int64)
    return row, col


def project(xyz, remission, labels, use_remission: bool = False, height=HEIGHT, width=WIDTH) -> Projection:
    """The range image of one scan: channels range/30 m, x/30, y/30, z/30 (remission last
    when asked), the labels, the mask of filled pixels."""
    xyz = np.asarray(xyz, dtype=np.float32)
    r = np.linalg.norm(xyz, axis=1)
    row, col = pixel_of(xyz, height, width)
    channels = [r / RANGE_SCALE, *(xyz[:, k] / RANGE_SCALE for k in range(3))]
    if use_remission:
        channels.append(np.asarray(remission, dtype=np.float32))
    order = np.argsort(-r, kind="stable")  # far first: the nearest point of a pixel is written last
    image = np.zeros((len(channels), height, width), dtype=np.float32)
    for k, values in enumerate(channels):
        image[k, row[order], col[order]] = values[order]
    label_image = np.zeros((height, width), dtype=np.int64)
    label_image[row[order], col[order]] = np.asarray(labels)[order]
    mask = np.zeros((height, width), dtype=bool)
    mask[row, col] = True
    return Projection(image, label_image, mask, row, col)


def iou_table(confusion: np.ndarray, ignore: frozenset[int]) -> dict[int, float]:
    """IoU = TP / (TP + FP + FN) per class with points (confusion: rows truth, columns prediction)."""
    tp = np.diag(confusion).astype(np.float64)
    union = confusion.sum(axis=0) + confusion.sum(axis=1) - tp
    return {k: float(tp[k] / union[k]) for k in range(len(tp)) if k not in ignore and confusion[k].sum() > 0}
