"""WildScenes' 3D layout (csiro-robotics/WildScenes at 9eb4e10b, numpy only): per scan a
`Clouds/NAME.bin` of float32 x y z (no intensity) and a `Labels/NAME.label` of int32 class ids,
one a point in the same order, as its scripts/visualisation/view_cloud.py reads them
(np.fromfile(cloud, dtype=np.float32).reshape(-1, 3), np.fromfile(labels, dtype=np.int32)).
In a dataset a sequence folder is a WildScenes traverse (sequences/NN/Clouds, .../Labels).

The ids are the dataset's label scheme's (`wildscenes`: utils3d.py's 0-14, 255 unlabelled);
a single scan (`wildscan scan --format wildscenes`) writes WildScenes' own.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .writer import ScanFile, ScanOutput, Writer


def encode(scan: ScanOutput, paths: dict[str, Path]) -> dict[str, bytes]:
    cloud = scan.cloud
    return {
        "clouds": np.asarray(cloud.xyz, dtype="<f4").tobytes(),
        "clouds_labels": scan.labels.map(cloud.label).astype("<i4").tobytes(),
    }


WRITER = Writer(
    name="wildscenes",
    title="WildScenes",
    writes="WildScenes: Clouds/ .bin (float32 x y z) + Labels/ .label (int32 class ids)",
    files=(ScanFile("clouds", ".bin", "Clouds"), ScanFile("clouds_labels", ".label", "Labels")),
    scan_labels="wildscenes",
    encode=encode,
)
