"""A torch Dataset over a WildScan dataset's range images (data.py does the work; this only
turns its arrays into tensors)."""

from __future__ import annotations

from pathlib import Path

import torch
from torch.utils.data import Dataset

from .data import HEIGHT, WIDTH, load_label_config, project, read_scan, scan_files


class WildScanRangeImages(Dataset):
    """Range images of the scans of one split ("train", "valid" or "test", as labels.yaml
    lists its sequences): (image (C, H, W) float32, labels (H, W) int64) per scan."""

    def __init__(self, root, split: str = "train", use_remission: bool = False, weights: str = "enet",
                 height: int = HEIGHT, width: int = WIDTH):  # fmt: skip
        self.root = Path(root)
        self.config = load_label_config(self.root, weights)
        self.files = scan_files(self.root, self.config.split.get(split, []))
        self.use_remission, self.height, self.width = use_remission, height, width

    def __len__(self) -> int:
        return len(self.files)

    def __getitem__(self, index: int):
        xyz, remission, labels = read_scan(*self.files[index], self.config)
        p = project(xyz, remission, labels, self.use_remission, self.height, self.width)
        return torch.from_numpy(p.image), torch.from_numpy(p.labels)

    @property
    def class_weights(self) -> torch.Tensor:
        """Per learning class, from labels.yaml (0 for ignored classes): CrossEntropyLoss's weight."""
        return torch.from_numpy(self.config.weight_vector())
