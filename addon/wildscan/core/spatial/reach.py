"""How far from the world origin a scan still meets 1e-4 m, and the refusal beyond. Numpy only.

Checked by `wildscan bench --suite far` (docs/accuracy.md "Far from the origin"): the fast
backends (embree, bvh) cast in float32 relative to a local origin near the scan and refine in
float64, so sensor- and leveled-frame points meet 1e-4 m anywhere poses
are accepted (+-1e6 m, placement.MAX_COORDINATE). Two things are float32 in world
coordinates and stop short of that:

- a world-frame PLY stores x, y, z as float32 (PLY_FIELDS, a file contract): its rounding is
  half a float32 step, 61 um per coordinate below 2048 m and 122 um from 2048 m to 4096 m.
  Points within 2048 m in x and y and 1024 m in z (30 um) stay within 92 um of the truth.
- scene.ray_cast (the blender backend) takes its ray origin in float32: beyond 2048 m it is
  moved by more than 61 um per coordinate, so near an edge it reports another face than
  the float64 geometry does, whatever the frame.

So a scan in the world frame, or with the blender backend, is refused when the sensor's
reach (optical centre +- max range) leaves that box.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError

FLOAT32_XY_REACH = 2048.0  # m: |x|, |y| of every point below this (float32 steps <= 0.12 mm)
FLOAT32_Z_REACH = 1024.0  # m: |z| below this (steps <= 61 um), so x, y, z together stay < 1e-4 m


def float32_reach_exceeded(centre, max_range: float) -> str | None:
    """Which coordinate of the reach (centre +- max_range; centre (3,) or many (N, 3), as a
    drive's) leaves the float32 box, said in words (None when all stay inside)."""
    centres = np.asarray(centre, dtype=np.float64).reshape(-1, 3)
    if not len(centres):
        return None
    farthest = centres[np.argmax(np.abs(centres), axis=0), [0, 1, 2]]  # signed, per axis
    for axis, value, limit in zip("xyz", farthest, (FLOAT32_XY_REACH, FLOAT32_XY_REACH, FLOAT32_Z_REACH)):
        if abs(float(value)) + max_range >= limit:
            return f"{axis} = {float(value):g} m (+- {max_range:g} m range) reaches past +-{limit:g} m"
    return None


def check_reach(centre, max_range: float, frame: str, backend: str) -> None:
    """Refuse a scan (or a drive: every optical centre (N, 3)) whose numbers would not meet
    1e-4 m this far from the origin."""
    beyond = float32_reach_exceeded(centre, max_range)
    if beyond is None:
        return
    if frame == "world":
        raise UserError(
            f"world: the scan's sensor is too far from the origin for float32 PLY coordinates to "
            f"meet 1e-4 m ({beyond}); use the leveled or sensor frame (the placement is in the "
            "metadata), or move the scene nearer the origin",
            setting="frame",
            allowed=("leveled", "sensor"),
        )
    if backend == "blender":
        raise UserError(
            f"blender: scene.ray_cast takes float32 ray origins, too coarse this far from the origin "
            f"to meet 1e-4 m ({beyond}); use the embree or bvh backend",
            setting="backend",
            allowed=("embree", "bvh"),
        )
