"""LAS 1.4 (point format 7: xyz, intensity, classification, RGB) through `laspy`.

Classification is an ASPRS code (LAS 1.4 R15, table 17); WildScan classes without an
ASPRS class get user codes from 64 up. The file carries the table itself in a
Classification Lookup VLR, and extra dimensions (LAS "extra bytes") keep what ASPRS
codes lose: `wildscan_label`, `label` (the dataset's label scheme), `instance`, `ring`,
`sweep`, `range` and, in a dataset, `hag` (height above the ground the robot stands on).
Intensity is the scan's (paper model: the element's Table I reflectivity, 15..100); colours
are the class colours (16-bit).

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
from pathlib import Path

import numpy as np

from ... import __version__
from ..classes import BY_ID, COLOR_BY_ID, WATER_ID
from ..label_schemes import SchemeError, ids_by_class_id
from .writer import ScanFile, ScanOutput, Writer

# WildScan class -> ASPRS classification code (LAS 1.4 R15 table 17), checked at import like the
# label schemes (core/label_schemes.py): every class of core/classes.py needs one entry.
ASPRS_BY_CLASS: dict[str, int] = {
    "unlabeled": 1,  # unclassified
    "terrain": 2,  # (and flooring) ground
    "trunk": 64,  # user code
    "treetop": 5,  # high vegetation
    "table": 65,  # user code
    "bush": 4,  # medium vegetation
    "fence": 66,  # user code
    "bench": 67,  # user code
    "low grass": 3,  # low vegetation
    "rock": 68,  # user code
    "high grass": 4,  # medium vegetation
    "wire": 14,  # wire conductor (phase)
    "pole": 15,  # transmission tower
    "water": 9,  # water: never written (a beam that hits water returns no point), so not in ASPRS_NAMES
    "log": 69,  # user code: ASPRS has no deadwood class
    "particle": 18,  # high noise (returns from the air: rain, snow, fog, dust)
    # the endless landscape's ground materials are ground (ASPRS codes what a surface is, not
    # what it is made of)
    "soil": 2,
    "gravel": 2,
    "mud": 2,
    "paved": 2,
    "leaf litter": 2,
    "rock slab": 2,
}
ASPRS_CODES: dict[int, int] = ids_by_class_id("asprs (core/io/las.py)", ASPRS_BY_CLASS, None)  # id -> code
ASPRS_NAMES: dict[int, str] = {
    1: "unclassified",
    2: "ground",
    3: "low vegetation",
    4: "medium vegetation",
    5: "high vegetation",
    14: "wire conductor",
    15: "transmission tower",
    18: "high noise",
    64: "trunk",
    65: "table",
    66: "fence",
    67: "bench",
    68: "rock",
    69: "log",
}
_UNNAMED = sorted({code for i, code in ASPRS_CODES.items() if i != WATER_ID and code not in ASPRS_NAMES})
if _UNNAMED:  # a point's code must be named in the file's Classification Lookup VLR
    raise SchemeError(f"ASPRS codes {_UNNAMED} (ASPRS_BY_CLASS, core/io/las.py) have no name in ASPRS_NAMES")
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
# a dual-return scan's (core/sensors/returns.py RETURN_TYPES): which return of its beam a point is
RETURN_TYPE_DIMENSION = ("return_type", np.uint8, "1 strong,2 last,3 both,4 second")
# extra dimensions of a scan by a device other than the default (core/sensors; the default
# device's files keep their bytes): the firing's index and time, also the point's GPS time
DEVICE_DIMENSIONS: tuple[tuple[str, type, str], ...] = (
    ("column", np.uint32, "firing or 2D scan index"),
    ("time", np.float64, "s after the scan's first beam"),
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
    """One scan as LAS 1.4 bytes. `fields` holds instance, ring, sweep and range, hag where
    the terrain is known (datasets; without it the file has no `hag` dimension), and for a
    realistic-model scan echo, echoes, label_purity and mixed."""
    import laspy

    realistic = "echo" in fields
    dimensions = tuple(d for d in EXTRA_DIMENSIONS if d[0] != "hag" or "hag" in fields)
    dimensions += REALISTIC_DIMENSIONS if realistic else ()
    dimensions += DEVICE_DIMENSIONS if "column" in fields else ()
    dimensions += (RETURN_TYPE_DIMENSION,) if "return_type" in fields else ()
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
    if "column" in fields:  # a firing time, as a lidar's LAS export gives it (s, scan-relative)
        las.gps_time = np.asarray(fields["time"], dtype=np.float64)
    out = io.BytesIO()
    las.write(out)
    return out.getvalue()


def encode(scan: ScanOutput, paths: dict[str, Path]) -> dict[str, bytes]:
    """The format table's LAS writer (formats.py). In the world frame the offsets are the
    optical centre rounded to the metre, so the scale's 0.1 mm steps hold far from the origin."""
    cloud = scan.cloud
    fields = {"instance": cloud.instance, "ring": cloud.ring, "sweep": cloud.sweep, "range": cloud.range}
    fields.update(cloud.extra)  # the realistic model's echo, echoes, label_purity, mixed
    if scan.hag is not None:
        fields["hag"] = scan.hag
    offsets = np.zeros(3)
    if cloud.frame == "world":
        offsets = np.round(np.asarray(scan.metadata["placement"]["optical_centre"], dtype=np.float64))
    mapped = scan.labels.map(cloud.label)
    return {"las": las_bytes(cloud.xyz, cloud.intensity, cloud.label, mapped, fields, __version__, offsets)}


WRITER = Writer(
    name="las",
    title="LAS 1.4",
    writes="LAS 1.4: ASPRS classification, intensity, class colours; WildScan label, instance as extra bytes",
    files=(ScanFile("las", ".las", "las"),),
    scan_labels="wildscan",
    encode=encode,
)


def asprs_table_rows() -> list[tuple[int, str, str]]:
    """(ASPRS code, its name, the WildScan classes it holds): the LAS table of docs/formats.md."""
    rows = []
    for code, name in sorted(ASPRS_NAMES.items()):
        held = [BY_ID[w].name for w, c in ASPRS_CODES.items() if c == code]
        rows.append((code, name, ", ".join(held)))
    return rows
