"""The one table of output formats (numpy only): name -> Writer (writer.py), used by
`wildscan scan --format`, a dataset's `formats`, `wildscan drive` and the add-on's export.

Adding a format (docs/extending.md "Add a format"): a module in core/io/ with an
`encode(scan, paths) -> {kind: bytes}` function and its `WRITER = Writer(...)` record (ply.py,
las.py, semantickitti.py are the examples), and its name as one line in WRITERS below. The
order of WRITERS is the order a dataset lists its formats in (its config hash depends on it):
add new formats at the end.

A single scan (`wildscan scan --format NAME --out FILE`): --out names the format's first
file and must end in its suffix; the others go beside it, same name, their own suffix:

    ply            SCAN.ply + SCAN.json (the sidecar)
    las            SCAN.las
    semantickitti  SCAN.bin (velodyne: x y z remission) + SCAN.label (SemanticKITTI ids)
    wildscenes     SCAN.bin (x y z) + SCAN.label (int32 WildScenes ids)
"""

from __future__ import annotations

import os
from importlib import import_module
from pathlib import Path

from ..errors import UserError
from ..label_schemes import scheme
from . import semantickitti
from .files import WORLD_SIDECAR_KEYS, atomic_outputs, check_output_path, write_durably, writing_to
from .writer import ScanOutput, Writer

DEFAULT_FORMAT = "ply"


def _table(*modules: str) -> dict[str, Writer]:
    """name -> the WRITER of each module of core/io named (adding a format is its module and its
    name here); a single scan's files must differ in suffix (they share --out's name)."""
    table = {}
    for writer in (import_module(f"{__package__}.{module}").WRITER for module in modules):
        suffixes = [f.suffix for f in writer.scan_files]
        if writer.name in table or len(set(suffixes)) != len(suffixes):
            raise ValueError(f"format {writer.name!r}: listed twice, or two files of a scan share a suffix")
        table[writer.name] = writer
    return table


WRITERS: dict[str, Writer] = _table(
    "semantickitti",
    "las",
    "ply",
    "wildscenes",
)
FORMATS: tuple[str, ...] = tuple(WRITERS)


def writer(name: str, setting: str = "format") -> Writer:
    """The writer of format `name`, or UserError naming `setting` and the formats there are."""
    if name not in WRITERS:
        raise UserError(
            f"must be one of {', '.join(FORMATS)}, got {name!r}", setting=setting, allowed=FORMATS
        )
    return WRITERS[name]


def scan_paths(w: Writer, out: Path) -> dict[str, Path]:
    """kind -> file of a single scan: `out` for the first, the others beside it."""
    return {f.kind: (out if i == 0 else out.with_suffix(f.suffix)) for i, f in enumerate(w.scan_files)}


def check_scan_output(w: Writer, out: str | os.PathLike, setting: str = "out") -> Path:
    """The resolved --out of a single scan in format `w`, or UserError saying why it (or a file
    beside it) cannot be written. For PLY this is ply.check_output_path."""
    companions = tuple(f.suffix for f in w.scan_files[1:])
    # a world's sidecar is never replaced by a scan's
    foreign = WORLD_SIDECAR_KEYS if ".json" in companions else None
    return check_output_path(out, w.suffix, setting, companions=companions, foreign_sidecar_key=foreign)


def check_ascii(w: Writer, ascii: bool) -> None:
    if ascii and not w.ascii:
        ascii_formats = ", ".join(name for name, other in WRITERS.items() if other.ascii)
        why = f"applies to {{format}} {ascii_formats} only, not to {w.name}"
        raise UserError(why, setting="ascii", related=("format",))


def single_scan(w: Writer, cloud, metadata: dict, ascii: bool = False, lost_cells=None) -> ScanOutput:
    """A scan on its own (no world around it): the label ids of the format's own scheme;
    `lost_cells`: its range image's `lost` mask (core/scan.py ScanResult.lost_cells)."""
    check_ascii(w, ascii)
    return ScanOutput(
        cloud=cloud, metadata=metadata, labels=scheme(w.scan_labels), ascii=ascii, lost_cells=lost_cells
    )


def range_image_bytes(w: Writer, scan: ScanOutput) -> bytes:
    """A single scan's range image (core/io/rangeimage.py), its labels and instances as the label
    file of format `w` has them (SemanticKITTI's .label: instances ranked; PLY and LAS: as is)."""
    cloud = scan.cloud
    instances = cloud.instance
    if w.name == semantickitti.WRITER.name:
        instances = semantickitti.instance_ranks(cloud.instance, cloud.instance)
    return semantickitti.range_image_bytes(scan, scan.labels.map(cloud.label), instances)


def write_scan(
    w: Writer, scan: ScanOutput, out: str | os.PathLike, range_image: Path | None = None
) -> list[Path]:
    """Write one scan in format `w` (and its range image to `range_image`, when given): every
    file under a temporary name, renamed into place together (all of them or none). Returns
    the files, --out first."""
    paths = scan_paths(w, check_scan_output(w, out))
    encoded = w.encode(scan, paths)  # everything that can fail on bad input, before the disk
    if range_image is not None:
        paths["rangeimage"] = range_image
        encoded["rangeimage"] = range_image_bytes(w, scan)
    finals = [paths[kind] for kind in encoded]
    with atomic_outputs(*finals) as temps:
        for tmp, final, data in zip(temps, finals, encoded.values(), strict=True):
            with writing_to(final):  # a write error names no file: say which one failed
                write_durably(tmp, lambda f, data=data: f.write(data))
    return finals
