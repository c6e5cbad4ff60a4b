"""LAS 1.4 (point format 7: xyz, intensity, classification, RGB) through `laspy`.

Classification is an ASPRS code (LAS 1.4 R15, table 17); WildScan classes without an
ASPRS class get user codes from 64 up. The file carries the table itself in a
Classification Lookup VLR, and extra dimensions (LAS "extra bytes") keep what ASPRS
codes lose: `wildscan_label`, `label` (the dataset's label scheme), `instance`, `ring`,
`sweep`, `range` and `hag` (height above the true terrain). Intensity is the scan's
(paper model: the element's Table I reflectivity, 15..100); colours are the class colours
(16-bit).

Echoes: a realistic-model scan's `echo` (1..3) and `echoes` (how many its beam returned)
are LAS's own return_number and number_of_returns, and its `label_purity` and `mixed`
become two more extra dimensions (REALISTIC_DIMENSIONS). A paper-model scan has one
return per beam (1 of 1) and no such dimensions: its bytes are what they were before.

Determinism: laspy stamps today's date into the header; it is fixed here so the same
scan always gives the same bytes. laspy is imported lazily (only LAS output needs it).
"""

from __future__ import annotations

import datetime
import io

import numpy as np

from ..classes import BY_ID, COLOR_BY_ID

# WildScan id -> ASPRS classification code
ASPRS_CODES: dict[int, int] = {
    0: 1,  # unlabeled -> unclassified
    1: 2,  # terrain (and flooring) -> ground
    2: 64,  # trunk (user code)
    3: 5,  # treetop -> high vegetation
    4: 65,  # table (user code)
    5: 4,  # bush -> medium vegetation
    6: 66,  # fence (user code)
    7: 67,  # bench (user code)
    8: 3,  # low grass -> low vegetation
    9: 68,  # rock (user code)
    10: 4,  # high grass -> medium vegetation
    11: 14,  # wire -> wire conductor (phase)
    12: 15,  # pole -> transmission tower
}
ASPRS_NAMES: dict[int, str] = {
    1: "unclassified",
    2: "ground",
    3: "low vegetation",
    4: "medium vegetation",
    5: "high vegetation",
    14: "wire conductor",
    15: "transmission tower",
    64: "trunk",
    65: "table",
    66: "fence",
    67: "bench",
    68: "rock",
}
FIXED_DATE = datetime.date(2000, 1, 1)  # LAS wants a creation date; a fixed one keeps bytes stable
SCALE = 1e-4  # m per integer step of x, y, z

# (name, numpy type, description) of the extra dimensions, in file order
EXTRA_DIMENSIONS: tuple[tuple[str, type, str], ...] = (
    ("wildscan_label", np.uint16, "WildScan class id"),
    ("label", np.uint16, "class id of the label scheme"),
    ("instance", np.uint32, "wildscan_instance of the element"),
    ("ring", np.uint16, "beam n in its 2D scan"),
    ("sweep", np.uint16, "2D scan m"),
    ("range", np.float32, "measured range, m"),
    ("hag", np.float32, "height above terrain, m"),
)
# extra dimensions of a realistic-model scan only (core/pointcloud.py OPTIONAL_FIELDS)
REALISTIC_DIMENSIONS: tuple[tuple[str, type, str], ...] = (
    ("label_purity", np.float32, "share of echo energy from label"),
    ("mixed", np.uint8, "1: a mixed pixel on no surface"),
)


def asprs_codes(wildscan_labels: np.ndarray) -> np.ndarray:
    table = np.zeros(max(BY_ID) + 1, dtype=np.uint8)
    for wildscan_id, code in ASPRS_CODES.items():
        table[wildscan_id] = code
    return table[np.asarray(wildscan_labels, dtype=np.intp)]


def _header(version: str, offsets: np.ndarray, dimensions):
    import laspy
    from laspy.vlrs.known import ClassificationLookupVlr

    header = laspy.LasHeader(point_format=7, version="1.4")
    header.creation_date = FIXED_DATE
    header.generating_software = f"WildScan {version}"[:32]
    header.system_identifier = "WildScan synthetic scan"
    header.scales = np.full(3, SCALE)
    header.offsets = np.asarray(offsets, dtype=np.float64)
    header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=t, description=d) for n, t, d in dimensions])
    lookup = ClassificationLookupVlr()
    for code, name in ASPRS_NAMES.items():
        lookup[code] = name[:15]
    header.vlrs.append(lookup)
    return header


def las_bytes(
    xyz: np.ndarray,
    intensity: np.ndarray,
    wildscan_label: np.ndarray,
    scheme_label: np.ndarray,
    fields: dict[str, np.ndarray],
    version: str,
    offsets=(0.0, 0.0, 0.0),
) -> bytes:
    """One scan as LAS 1.4 bytes. `fields` holds instance, ring, sweep, range and hag, and
    for a realistic-model scan echo, echoes, label_purity and mixed."""
    import laspy

    realistic = "echo" in fields
    dimensions = EXTRA_DIMENSIONS + (REALISTIC_DIMENSIONS if realistic else ())
    las = laspy.LasData(_header(version, np.asarray(offsets), dimensions))
    xyz = np.asarray(xyz, dtype=np.float64)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.intensity = np.rint(np.asarray(intensity, dtype=np.float64)).astype(np.uint16)
    one = np.ones(len(xyz), dtype=np.uint8)
    las.return_number = np.asarray(fields["echo"], dtype=np.uint8) if realistic else one
    las.number_of_returns = np.asarray(fields["echoes"], dtype=np.uint8) if realistic else one
    las.classification = asprs_codes(wildscan_label)
    rgb = COLOR_BY_ID[np.asarray(wildscan_label, dtype=np.intp)].astype(np.uint16) * 257
    las.red, las.green, las.blue = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    las.wildscan_label = np.asarray(wildscan_label, dtype=np.uint16)
    las.label = np.asarray(scheme_label, dtype=np.uint16)
    for name, _, _ in dimensions[2:]:
        setattr(las, name, fields[name])
    out = io.BytesIO()
    las.write(out)
    return out.getvalue()


def asprs_table_rows() -> list[tuple[int, str, str]]:
    """(ASPRS code, its name, the WildScan classes it holds): the LAS table of docs/formats.md."""
    rows = []
    for code, name in sorted(ASPRS_NAMES.items()):
        held = [BY_ID[w].name for w, c in ASPRS_CODES.items() if c == code]
        rows.append((code, name, ", ".join(held)))
    return rows
