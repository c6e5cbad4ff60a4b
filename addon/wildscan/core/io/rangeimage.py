"""Range images on a scan's native grid (numpy only): `wildscan scan --range-image FILE.npz`
and a dataset's `rangeimage/NNNNNN.npz` beside each SemanticKITTI `.bin` (docs/formats.md).

Every beam of a scan has a cell: its row is the beam's ring (the 2D scanner's beam n for the
UTM-30LX-EW; a multi-beam lidar's ring, 0 = lowest elevation) and its column the column it
fired in (the 2D scan m of a rotating head; a spinning lidar's firing). The grid is
(beams a column) x (columns a scan), so the image needs no projection and loses no beam: a
cell holds its beam's point, the nearest when a beam returned several echoes (the realistic
model), as semantic-kitti-api's projection keeps the nearest of the points in a pixel.

`range_image(row, column, shape, ...)` takes the per-point cells and the grid shape and
nothing about the device: any device whose points carry a ring and a column plugs in.

The .npz holds, H x W (rows x columns):
    range      float32  metres (noise included), -1 where the beam returned no point
    intensity  float32  the .bin's remission (0..1, docs/formats.md "Intensity"), -1 where no point
    label      uint16   class id as the scan's label file has it (0 where no point)
    instance   uint32   instance as the scan's label file has it (0 where no point)
    mask       bool     the cell holds a point
    index      int32    which point (row of the .bin / PLY) the cell holds, -1 for none
and, one entry a point in the order of the scan's files:
    row        uint16   the point's row
    column     uint32   the point's column (a head turning a multi-beam lidar fires past 65,535)
and, for a scan of the realistic model (its detection step: core/realism/lost_returns.py):
    lost       bool     H x W: the beam met a surface but its return was too weak for the
                        receiver (no point): the ray-drop mask
"""

from __future__ import annotations

import io
import zipfile

import numpy as np

from ..pointcloud import PointCloud

NO_DATA = -1  # range, intensity and index of a cell without a point (semantic-kitti-api's)
# 1980-01-01, the earliest time a zip entry can state: the file's bytes never depend on the clock
ZIP_TIME = (1980, 1, 1, 0, 0, 0)
ARRAYS = ("range", "intensity", "label", "instance", "mask", "index", "row", "column")


def grid_shape(metadata: dict) -> tuple[int, int]:
    """(rows, columns) of a scan's grid from its metadata (core/scan.py run_scan): the beams of
    one column by the columns of one scan."""
    sensor = metadata["sensor"]
    return int(sensor["beams_per_2d_scan"]), int(sensor["sweeps"])


def cells_of(cloud: PointCloud) -> tuple[np.ndarray, np.ndarray]:
    """Each point's (row, column): its ring, and the column it was measured in (a device's
    `column` field where it has one, else the 2D scan `sweep`)."""
    column = cloud.extra.get("column", cloud.sweep)
    return np.asarray(cloud.ring, dtype=np.uint16), np.asarray(column, dtype=np.uint32)


def range_image(
    row: np.ndarray,
    column: np.ndarray,
    shape: tuple[int, int],
    range_m: np.ndarray,
    intensity: np.ndarray,
    label: np.ndarray,
    instance: np.ndarray,
) -> dict[str, np.ndarray]:
    """The ARRAYS of a range image of `shape` (rows, columns) holding the points at cells
    (`row`, `column`): per cell the nearest point's range, intensity, label and instance."""
    rows, cols = shape
    row = np.asarray(row, dtype=np.int64)
    column = np.asarray(column, dtype=np.int64)
    if len(row) and (row.max() >= rows or column.max() >= cols):
        raise ValueError(f"a point's cell lies outside the {rows} x {cols} grid")
    cell = row * cols + column
    if len(cell) and np.bincount(cell, minlength=rows * cols).max() > 1:
        # nearest last, so it is the one the assignment keeps (a stable sort: ties keep file order)
        order = np.lexsort((-np.arange(len(cell)), -np.asarray(range_m, dtype=np.float64)))
    else:
        order = np.arange(len(cell))  # a point a cell at most (one echo a beam): nothing to choose
    index = np.full(rows * cols, NO_DATA, dtype=np.int32)
    index[cell[order]] = order
    held = index >= 0
    return {
        "range": _cells(range_m, index, held, np.float32, NO_DATA).reshape(shape),
        "intensity": _cells(intensity, index, held, np.float32, NO_DATA).reshape(shape),
        "label": _cells(label, index, held, np.uint16, 0).reshape(shape),
        "instance": _cells(instance, index, held, np.uint32, 0).reshape(shape),
        "mask": held.reshape(shape),
        "index": index.reshape(shape),
        "row": row.astype(np.uint16),
        "column": column.astype(np.uint32),
    }


def _cells(values, index: np.ndarray, held: np.ndarray, dtype, empty) -> np.ndarray:
    out = np.full(len(index), empty, dtype=dtype)
    out[held] = np.asarray(values)[index[held]]
    return out


def scan_range_image(
    cloud: PointCloud,
    metadata: dict,
    remission: np.ndarray,
    labels: np.ndarray,
    instances: np.ndarray,
    lost_cells: tuple[np.ndarray, np.ndarray] | None = None,
) -> dict[str, np.ndarray]:
    """The range image of a scan whose SemanticKITTI files carry `remission`, `labels` and
    `instances` (per point); with `lost_cells` ((rows, columns) of the beams the detection
    step dropped: core/scan.py ScanResult) its `lost` mask too."""
    row, column = cells_of(cloud)
    shape = grid_shape(metadata)
    image = range_image(row, column, shape, cloud.range, remission, labels, instances)
    if lost_cells is not None:
        lost = np.zeros(shape, dtype=bool)
        lost[np.asarray(lost_cells[0], dtype=np.int64), np.asarray(lost_cells[1], dtype=np.int64)] = True
        image["lost"] = lost
    return image


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """An .npz that np.load reads, byte-identical for the same arrays: np.savez stamps each
    entry with the clock, so the zip is written here, entries stored (deflate's bytes depend
    on the zlib build) and dated ZIP_TIME."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        for name, array in arrays.items():
            entry = zipfile.ZipInfo(f"{name}.npy", date_time=ZIP_TIME)
            entry.external_attr = 0o644 << 16  # rw-r--r--, as np.savez's entries unpack
            data = io.BytesIO()
            np.lib.format.write_array(data, np.ascontiguousarray(array), allow_pickle=False)
            archive.writestr(entry, data.getvalue())
    return buffer.getvalue()
