"""Read PLY files with Open3D's two readers and save what they loaded (run by
reader_helpers.open3d_read in a child process, since Open3D aborts the process on a
header it cannot take).

    python open3d_probe.py WORK I1 FILE1 [I2 FILE2 ...]

For each file: WORK/open3d-I.npz with `tensor.<attribute>` (o3d.t.io.read_point_cloud:
every attribute it kept, with its dtype) and `legacy.points`, `legacy.colors`
(o3d.io.read_point_cloud), then the line `read I` on stdout.
"""

import sys
from pathlib import Path

import numpy as np
import open3d as o3d


def read(path: str) -> dict[str, np.ndarray]:
    tensor = o3d.t.io.read_point_cloud(path)
    arrays = {f"tensor.{name}": tensor.point[name].numpy() for name in tensor.point}
    legacy = o3d.io.read_point_cloud(path)
    arrays["legacy.points"] = np.asarray(legacy.points)
    arrays["legacy.colors"] = np.asarray(legacy.colors)
    return arrays


def main(argv: list[str]) -> None:
    work, pairs = Path(argv[0]), argv[1:]
    for index, path in zip(pairs[::2], pairs[1::2]):
        np.savez(work / f"open3d-{index}.npz", **read(path))
        print("read", index, flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
