"""Park furniture: picnic table, bench and fence, built of boxes."""

from __future__ import annotations

from .primitives import Mesh, box, merge


def table() -> Mesh:
    """Picnic table, 1.8 m x 0.8 m top at 0.75 m, heading along X."""
    parts = [box((0, 0, 0.75), (1.8, 0.8, 0.05))]
    for sx in (-0.75, 0.75):
        for sy in (-0.3, 0.3):
            parts.append(box((sx, sy, 0.31), (0.07, 0.07, 0.82)))
    return merge(parts)


def bench() -> Mesh:
    """Park bench, 1.6 m long, seat at 0.45 m, backrest on the -Y side."""
    parts = [box((0, 0, 0.45), (1.6, 0.42, 0.05)), box((0, -0.19, 0.75), (1.6, 0.05, 0.3))]
    for sx in (-0.7, 0.7):
        parts.append(box((sx, 0.15, 0.16), (0.06, 0.06, 0.52)))
        parts.append(box((sx, -0.19, 0.36), (0.06, 0.06, 0.92)))
    return merge(parts)


def fence_post() -> Mesh:
    return box((0, 0, 0.45), (0.1, 0.1, 1.3))


def fence_section(length: float) -> Mesh:
    """A post at x=0 and two rails reaching the next section's post at x=length."""
    return merge(
        [
            fence_post(),
            box((length / 2, 0, 0.45), (length - 0.1, 0.04, 0.1)),
            box((length / 2, 0, 0.9), (length - 0.1, 0.04, 0.1)),
        ]
    )
