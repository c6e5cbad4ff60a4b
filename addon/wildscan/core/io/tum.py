"""The TUM RGB-D trajectory format (numpy only): one pose a line, `t x y z qx qy qz qw`
(seconds, metres, a unit quaternion of the body's rotation into the world frame), the
format evo, the TUM benchmark tools and most SLAM evaluations read. Lines starting with
`#` are comments."""

from __future__ import annotations

import numpy as np

from ..spatial.rotations import quaternions

HEADER = "# t x y z qx qy qz qw"


def tum_text(times: np.ndarray, positions: np.ndarray, rotations: np.ndarray, comment: str = "") -> str:
    """The trajectory as TUM text; `rotations` (K, 3, 3) take the body frame to the world."""
    q = quaternions(rotations)
    rows = np.column_stack([np.asarray(times, dtype=np.float64), positions, q])
    head = [f"# {line}" for line in comment.splitlines()] + [HEADER]
    body = [
        f"{r[0]:.6f} {r[1]:.9f} {r[2]:.9f} {r[3]:.9f} {r[4]:.12f} {r[5]:.12f} {r[6]:.12f} {r[7]:.12f}"
        for r in rows
    ]
    return "\n".join(head + body) + "\n"


def read_tum(text: str) -> np.ndarray:
    """(K, 8) rows of a TUM trajectory (comments skipped)."""
    rows = [line.split() for line in text.splitlines() if line.strip() and not line.startswith("#")]
    return np.array(rows, dtype=np.float64).reshape(-1, 8)
