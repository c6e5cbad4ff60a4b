"""The triangles a scan's beams can reach (numpy only): `BeamGrid(directions).reachable(...)`.

A scan's beams leave one optical centre in fixed directions (the device's rings and columns
turned by the placement). A triangle no beam direction points into cannot be any beam's hit,
so a caster that never holds it gives the same answers for less work. Far away that is most
triangles: a leaf cluster 80 m off spans ~0.1 deg, while a 100 m lidar's beams are 0.2-2 deg
apart, so about one in five of a far tile's leaves lies on a beam (bench --suite lod).

The test is conservative, never exact-to-the-edge: the beams' directions are binned on a
grid of 0.02-0.05 deg cells in (azimuth, elevation) as seen from the optical centre; a triangle
is kept when any occupied cell meets its angular box widened by a margin (float32 casting
tolerance, and for a realistic beam its divergence, the spread of its sub-rays). The box
bounds every direction that meets the triangle:

- azimuth: the triangle's xy projection, away from the centre, is seen within the arc of
  its corners (a wide arc, over WIDE_RAD, or one round the centre: the triangle is kept);
- elevation: z / rho over the triangle lies between its corners' extreme z over the least
  and the greatest horizontal distance (the least: its xy box's nearest point; the greatest:
  a corner, rho being convex).

A summed-area table of the occupied cells answers each triangle in four lookups.
"""

from __future__ import annotations

import math

import numpy as np

# The grid's cell: the finest of FINE_CELL_RAD .. CELL_RAD whose table stays within MAX_CELLS
# (a triangle's box is widened to whole cells, so the finer, the more far leaves are left out;
# every device's beams are >= 0.08 deg apart, coarser than the coarsest cell)
CELL_RAD = math.radians(0.05)
FINE_CELL_RAD = math.radians(0.02)
MAX_CELLS = 8_000_000  # int32: 32 MB, summed in ~0.1 s (24 M took 0.25-0.9 s for 12 % fewer triangles)
MARGIN_RAD = 2e-4  # rad: far above float32's casting error on a triangle's edge (~1e-7 rad)
WIDE_RAD = math.pi / 2  # a triangle seen over a wider arc of azimuth is kept without a test


class BeamGrid:
    """The directions of a scan's beams, binned for `reachable`."""

    def __init__(self, directions: np.ndarray, margin_rad: float = MARGIN_RAD):
        d = np.asarray(directions, dtype=np.float64)
        az = np.arctan2(d[:, 1], d[:, 0])
        el = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]))
        self.margin = float(margin_rad)
        band = float(el.max()) - float(el.min()) + 2 * self.margin
        self.cell = max(FINE_CELL_RAD, min(CELL_RAD, math.sqrt(band * 2 * math.pi / MAX_CELLS)))
        self.columns = int(math.ceil(2 * math.pi / self.cell))
        self.el0 = float(el.min()) - self.margin - self.cell  # the grid's rows span the beams' band
        rows = int((float(el.max()) + self.margin + self.cell - self.el0) / self.cell) + 2
        self.rows = rows
        occupied = np.zeros((rows + 1, self.columns + 1), dtype=np.int32)
        occupied[self._row(el) + 1, self._column(az) + 1] = 1
        np.cumsum(occupied, axis=0, out=occupied)  # in place: the table is its own summed areas
        np.cumsum(occupied, axis=1, out=occupied)
        self.table = occupied

    def _row(self, el) -> np.ndarray:
        row = np.floor((el - np.float32(self.el0)) / np.float32(self.cell)).astype(np.int64)
        return np.clip(row, 0, self.rows - 1)

    def _column(self, az) -> np.ndarray:
        return np.floor((np.asarray(az) + math.pi) / self.cell).astype(np.int64) % self.columns

    def _count(self, r0, r1, c0, c1) -> np.ndarray:
        """Occupied cells in rows r0..r1, columns c0..c1 (inclusive, c0 <= c1 < columns)."""
        t = self.table
        return t[r1 + 1, c1 + 1] - t[r0, c1 + 1] - t[r1 + 1, c0] + t[r0, c0]

    def reachable(self, vertices: np.ndarray, faces: np.ndarray, origin, around=None) -> np.ndarray:
        """(T,) bool: the triangles some beam from `origin` (world metres, as `vertices`) may
        meet; False only where none can. `around` = ((x, y), r): the triangles whose xy box
        comes within r of (x, y) are kept too."""
        # float32 (half the memory traffic of float64): its angles are within ~1e-6 rad, far
        # inside the margin, at every distance a tile reaches
        v = (np.asarray(vertices, dtype=np.float64) - np.asarray(origin, dtype=np.float64)).astype(np.float32)
        faces = np.asarray(faces)
        x, y, z = v[:, 0], v[:, 1], v[:, 2]
        az_v = np.arctan2(y, x)
        lo, hi = _corner_range(az_v, faces)
        over = np.flatnonzero(hi - lo > math.pi)  # the arc crosses -x: measured from there instead
        if len(over):
            turned = np.where(az_v < 0, az_v + np.float32(2 * math.pi), az_v)
            lo[over], hi[over] = _corner_range(turned, faces[over])
        wide = hi - lo > WIDE_RAD
        x_lo, x_hi = _corner_range(x, faces)
        y_lo, y_hi = _corner_range(y, faces)
        z_lo, z_hi = _corner_range(z, faces)
        rho_far = _corner_range(np.hypot(x, y), faces)[1]
        zero = np.float32(0.0)
        rho_near = np.hypot(np.clip(zero, x_lo, x_hi), np.clip(zero, y_lo, y_hi))
        el_hi = np.arctan2(z_hi, np.where(z_hi > 0, rho_near, rho_far))
        el_lo = np.arctan2(z_lo, np.where(z_lo > 0, rho_far, rho_near))
        m = np.float32(self.margin)
        r0, r1 = self._row(el_lo - m), self._row(el_hi + m)
        cell = np.float32(self.cell)
        c0 = np.floor((lo - m + np.float32(math.pi)) / cell).astype(np.int64)
        c1 = np.floor((hi + m + np.float32(math.pi)) / cell).astype(np.int64)
        shift = np.floor_divide(c0, self.columns) * self.columns  # c0 into 0..columns-1
        c0, c1 = c0 - shift, c1 - shift
        n = self.columns
        count = self._count(r0, r1, c0, np.minimum(c1, n - 1))
        past = c1 >= n  # the arc runs past the grid's last column: the rest from column 0
        if past.any():
            count[past] += self._count(r0[past], r1[past], 0 * c0[past], np.minimum(c1[past] - n, n - 1))
        keep = wide | (count > 0)
        if around is not None:
            (px, py), r = around
            px, py = np.float32(px - float(origin[0])), np.float32(py - float(origin[1]))
            gx, gy = np.clip(px, x_lo, x_hi) - px, np.clip(py, y_lo, y_hi) - py
            keep |= gx * gx + gy * gy <= r * r
        return keep


def _corner_range(values: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(least, greatest) of a per-vertex value over each triangle's three corners."""
    a, b, c = values.take(faces[:, 0]), values.take(faces[:, 1]), values.take(faces[:, 2])
    return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
