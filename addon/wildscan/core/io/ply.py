"""PLY + JSON sidecar writer (and a small reader) for WildScan point clouds.

Numpy only. The files are a contract with users (docs/architecture.md "Files"): the vertex
fields and their order come from `pointcloud.PLY_FIELDS` (plus the cloud's optional
fields, `pointcloud.OPTIONAL_FIELDS`, when it carries any), the header comments
carry the tool version, the scan metadata and the class table.

Writes are atomic: a scan either leaves both `scan.ply` and `scan.json` or
neither, so a crash or Ctrl-C never leaves a truncated cloud that a user
could mistake for a real (small) scan.
"""

from __future__ import annotations

import io
import json
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from ... import __version__
from ..classes import BY_ID, class_table_dict, class_table_lines, listed_classes, table_ids
from ..errors import UserError
from ..pointcloud import PointCloud
from . import files
from .files import atomic_outputs, write_durably, writing_to
from .writer import ScanFile, ScanOutput, Writer

# numpy kind+size -> PLY type name (the names plyfile, PCL and CloudCompare all read).
_PLY_TYPE_BY_CODE = {
    "f4": "float",
    "f8": "double",
    "u4": "uint",
    "i4": "int",
    "u2": "ushort",
    "i2": "short",
    "u1": "uchar",
    "i1": "char",
}
# Every spelling the PLY spec allows, for the reader.
_NUMPY_CODE_BY_PLY_TYPE = {
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
    "uint": "u4",
    "uint32": "u4",
    "int": "i4",
    "int32": "i4",
    "ushort": "u2",
    "uint16": "u2",
    "short": "i2",
    "int16": "i2",
    "uchar": "u1",
    "uint8": "u1",
    "char": "i1",
    "int8": "i1",
}
_FORMATS = {"binary_little_endian": "<", "binary_big_endian": ">", "ascii": "<"}

# Metadata keys written first in the header, in this order; the rest follow sorted.
_LEADING_KEYS = ("seed", "pose", "frame", "sensor")
# Written to the header by other means (the class table has its own lines).
_NOT_IN_HEADER = frozenset({"classes", "class_counts", "wildscan_version", "ply_file", "point_count"})
# Strings made only of these characters are written bare; others are JSON-quoted
# so a comment line stays one line of ASCII and `key=value` pairs stay unambiguous.
_PLAIN_TEXT = re.compile(r"[A-Za-z0-9_.,:/+\-]+")

# The longest header line written, `comment ` included. RPly -- the PLY library inside
# Open3D (both its readers) and CloudCompare -- copies each header line into a fixed
# 1,024-byte buffer: a `comment` line of 1,032 characters or more aborts the whole reading
# process ("buffer overflow detected"; measured with Open3D 0.20 and CloudCompare 2.11).
# Metadata with no short form (the four placement lasers, a long .blend path, the names of
# untagged objects) goes to the JSON sidecar only, and a key with many `key=value` pairs
# continues on further lines: every line stays short whatever the input.
MAX_HEADER_LINE = 200
_MAX_COMMENT = MAX_HEADER_LINE - len("comment ")
_MAX_KEY = 64  # a metadata key's text in the header (keys are ours, but keep the bound total)
# What a header value reads when the JSON sidecar alone holds it: a list of records, or a
# value too long for a header line. Not plain text, so no string value reads the same.
IN_SIDECAR = "<sidecar>"
# Metadata lists of unbounded length that the header only counts (`KEY count=N`).
_COUNTED_KEYS = frozenset({"untagged_objects_hit"})


# --------------------------------------------------------------------------- paths


def check_output_path(path: str | os.PathLike) -> Path:
    """The resolved PLY path, or UserError saying why it (or its sidecar) cannot be written."""
    # A world's sidecar (files.WORLD_SIDECAR_KEYS); a scan beside it must not replace it.
    return files.check_output_path(
        path, ".ply", "out", companions=(".json",), foreign_sidecar_key=files.WORLD_SIDECAR_KEYS
    )


def sidecar_path(ply_path: str | os.PathLike) -> Path:
    """Where the JSON metadata of a PLY file lives: same name, `.json` suffix."""
    return Path(ply_path).with_suffix(".json")


# --------------------------------------------------------------------------- header text


def _scalar_text(value: object) -> str:
    """One metadata value as header text: deterministic, one line, ASCII."""
    if value is None:
        return "null"
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # shortest text that round-trips
    if isinstance(value, np.ndarray):
        value = value.ravel().tolist()
    if isinstance(value, (list, tuple)):
        if any(isinstance(v, (dict, list, tuple)) for v in value):
            return IN_SIDECAR  # records (the four placement lasers) have no one-line form
        return ",".join(_scalar_text(v) for v in value)
    if isinstance(value, dict):
        return " ".join(_flatten_dict(value))
    text = str(value)
    return text if _PLAIN_TEXT.fullmatch(text) else json.dumps(text)  # json escapes \n and non-ASCII


def _key_text(key: object) -> str:
    text = str(key)
    text = text if _PLAIN_TEXT.fullmatch(text) else re.sub(r"[^A-Za-z0-9_.:/+\-]", "_", text) or "_"
    return text[:_MAX_KEY]


def _flatten_dict(d: dict, prefix: str = "") -> list[str]:
    """`{"a": 1, "b": {"c": 2}}` -> ["a=1", "b.c=2"], keys sorted for determinism."""
    pairs: list[str] = []
    for key in sorted(d, key=str):
        name = prefix + _key_text(key)
        value = d[key]
        if isinstance(value, dict) and value:
            pairs.extend(_flatten_dict(value, name + "."))
        else:
            pairs.append(f"{name}={_scalar_text(value)}")
    return pairs


def _fitted(key: str, pair: str) -> str:
    """`pair` (`name=value`, or a bare value) as it fits on a line after `key`: a value too
    long becomes IN_SIDECAR, and a name too long is cut."""
    room = _MAX_COMMENT - len(key) - 1
    if len(pair) <= room:
        return pair
    name, equals, _ = pair.partition("=")
    if not equals:
        return IN_SIDECAR
    return name[: max(1, room - len(IN_SIDECAR) - 1)] + "=" + IN_SIDECAR


def _packed(key: str, items: list[str]) -> list[str]:
    """`key item item …` lines of at most _MAX_COMMENT characters: a key whose pairs do not
    fit on one line repeats on the next (a reader joins the lines of a key)."""
    lines: list[str] = []
    line = key
    for item in (_fitted(key, item) for item in items):
        if line != key and len(line) + 1 + len(item) > _MAX_COMMENT:
            lines.append(line)
            line = key
        line += " " + item
    lines.append(line)
    return lines


def _header_value(key: object, value: object) -> object:
    if key in _COUNTED_KEYS and isinstance(value, (list, tuple, set, frozenset)):
        return {"count": len(value)}
    return value


def _metadata_comments(metadata: dict) -> list[str]:
    leading = [k for k in _LEADING_KEYS if k in metadata]
    rest = sorted((k for k in metadata if k not in _LEADING_KEYS and k not in _NOT_IN_HEADER), key=str)
    lines = []
    for key in (*leading, *rest):
        value = _header_value(key, metadata[key])
        if isinstance(value, dict) and value:
            lines.extend(_packed(_key_text(key), _flatten_dict(value)))
        else:
            text = _scalar_text(value)
            lines.extend(_packed(_key_text(key), [text] if text else []))
    return lines


def _ply_header(count: int, comments: list[str], ascii: bool, fields) -> bytes:
    fmt = "ascii" if ascii else "binary_little_endian"
    lines = ["ply", f"format {fmt} 1.0"]
    lines += [f"comment {c}" for c in comments]
    lines.append(f"element vertex {count}")
    for name, code in fields:
        np_code = np.dtype(code).str[1:]  # '<f4' -> 'f4', '|u1' -> 'u1'
        lines.append(f"property {_PLY_TYPE_BY_CODE[np_code]} {name}")
    lines.append("end_header")
    for line in lines:  # a stray newline or a long line would break the header for readers
        assert "\n" not in line and "\r" not in line, line
        assert len(line) <= MAX_HEADER_LINE, line
    return ("\n".join(lines) + "\n").encode("ascii")


def _ascii_formats(dtype: np.dtype) -> list[str]:
    # '%.9g' round-trips float32 exactly; integers print as integers.
    return ["%.9g" if dtype[name].kind == "f" else "%d" for name in dtype.names]


def header_comments(cloud: PointCloud, metadata: dict) -> list[str]:
    """The header comment texts (without the `comment ` keyword), in file order."""
    meta = _with_defaults(cloud, metadata)
    return [
        f"generated by WildScan {__version__}",
        *_metadata_comments(meta),
        *(f"class {line}" for line in class_table_lines(file_classes(cloud, meta))),
    ]


def file_classes(cloud: PointCloud, meta: dict):
    """The classes the header and the sidecar list, one answer for both (classes.listed_classes):
    those the scan's metadata lists (run_scan's, from what its effects declare) and those its
    points carry."""
    return listed_classes(cloud.label, table_ids(meta.get("classes")))


# --------------------------------------------------------------------------- sidecar


def _json_default(value: object) -> object:
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"metadata value {value!r} of type {type(value).__name__} is not JSON serialisable")


def _with_defaults(cloud: PointCloud, metadata: dict) -> dict:
    meta = dict(metadata)
    meta.setdefault("frame", cloud.frame)
    return meta


def _class_counts_by_name(cloud: PointCloud) -> dict[str, int]:
    return {(BY_ID[i].name if i in BY_ID else str(i)): n for i, n in cloud.class_counts().items()}


def sidecar_dict(ply_path: Path, cloud: PointCloud, metadata: dict, ascii: bool = False) -> dict:
    """What the JSON sidecar holds: the metadata plus facts about the file."""
    meta = _with_defaults(cloud, metadata)
    meta.setdefault("wildscan_version", __version__)
    meta["classes"] = class_table_dict(file_classes(cloud, meta))  # the header's, always
    # Facts of this very file: always computed, never taken from the caller.
    meta["ply_file"] = Path(ply_path).name
    meta["ply_format"] = "ascii" if ascii else "binary_little_endian"
    meta["point_count"] = len(cloud)
    meta["class_counts"] = _class_counts_by_name(cloud)
    return meta


def _sidecar_bytes(ply_path: Path, cloud: PointCloud, metadata: dict, ascii: bool) -> bytes:
    text = json.dumps(
        sidecar_dict(ply_path, cloud, metadata, ascii), indent=2, sort_keys=True, default=_json_default
    )
    return (text + "\n").encode("utf-8")


# --------------------------------------------------------------------------- writing


_ASCII_CHUNK = 65536  # rows formatted at a time: bounds memory on big scans


def _write_ascii_rows(f, records: np.ndarray) -> None:
    # Column-wise tolist + one %-format per row is about twice as fast as
    # np.savetxt, which builds a tuple from every structured record.
    row_format = " ".join(_ascii_formats(records.dtype)) + "\n"
    for start in range(0, len(records), _ASCII_CHUNK):
        chunk = records[start : start + _ASCII_CHUNK]
        columns = [chunk[name].tolist() for name in chunk.dtype.names]
        f.write("".join([row_format % row for row in zip(*columns, strict=True)]).encode("ascii"))


def _write_vertices(f, records: np.ndarray, ascii: bool) -> None:
    if ascii:
        _write_ascii_rows(f, records)
    else:
        f.write(records.tobytes())


def write_scan_files(
    ply_path: str | os.PathLike, cloud: PointCloud, metadata: dict, ascii: bool = False
) -> tuple[Path, Path]:
    """Write `cloud` as a PLY file plus its JSON sidecar; return both paths.

    Both files appear together or not at all, and the same inputs always give
    byte-identical files (no timestamps, sorted keys).
    """
    ply_path = check_output_path(ply_path)
    json_path = sidecar_path(ply_path)
    # Build everything that can fail on bad input before touching the disk.
    records = cloud.to_structured()
    header = _ply_header(len(records), header_comments(cloud, metadata), ascii, cloud.fields())
    sidecar = _sidecar_bytes(ply_path, cloud, metadata, ascii)

    with atomic_outputs(ply_path, json_path) as (tmp_ply, tmp_json):
        with writing_to(ply_path):  # a write error names no file: say which one failed
            write_durably(tmp_ply, lambda f: (f.write(header), _write_vertices(f, records, ascii)))
        with writing_to(json_path):
            write_durably(tmp_json, lambda f: f.write(sidecar))
    return ply_path, json_path


def scan_file_bytes(
    ply_path: Path, cloud: PointCloud, metadata: dict, ascii: bool = False
) -> tuple[bytes, bytes]:
    """The bytes of the PLY file and of its JSON sidecar, as `write_scan_files` writes them
    (for callers that write many files in one atomic group, and hash what they write)."""
    records = cloud.to_structured()
    header = _ply_header(len(records), header_comments(cloud, metadata), ascii, cloud.fields())
    body = io.BytesIO()
    _write_vertices(body, records, ascii)
    return header + body.getvalue(), _sidecar_bytes(Path(ply_path), cloud, metadata, ascii)


def encode(scan: ScanOutput, paths: dict[str, Path]) -> dict[str, bytes]:
    """The format table's PLY writer (formats.py): the PLY and its JSON sidecar, with a
    dataset's height above terrain as the optional `hag` field."""
    cloud = scan.cloud
    if scan.hag is not None:
        cloud = replace(cloud, extra={**cloud.extra, "hag": scan.hag})  # keeps the realistic model's fields
    if scan.support is not None:
        cloud = replace(cloud, extra={**cloud.extra, "support": scan.support})
    ply, sidecar = scan_file_bytes(Path(paths["ply"]), cloud, scan.metadata, scan.ascii)
    return {"ply": ply, "ply_sidecar": sidecar}


WRITER = Writer(
    name="ply",
    title="PLY",
    writes="PLY: x y z, intensity, WildScan label, instance, class colour, ring, sweep, range; JSON sidecar",
    files=(ScanFile("ply", ".ply", "ply"), ScanFile("ply_sidecar", ".json", "ply")),
    scan_labels="wildscan",
    encode=encode,
    ascii=True,
)


# --------------------------------------------------------------------------- reading


def _parse_header(f, path: Path) -> tuple[str, int, np.dtype, list[str]]:
    def fail(why: str) -> UserError:
        return UserError(f"cannot read {path}: {why}")

    if f.readline().rstrip(b"\r\n") != b"ply":
        raise fail("not a PLY file (no 'ply' magic line)")
    fmt, count, fields, comments = None, None, [], []
    element = None
    while True:
        raw = f.readline()
        if not raw:
            raise fail("header has no end_header line")
        line = raw.decode("ascii", errors="replace").rstrip("\r\n")
        words = line.split()
        if not words:
            continue
        if words[0] == "end_header":
            break
        if words[0] == "comment":
            comments.append(line[len("comment ") :] if line.startswith("comment ") else "")
        elif words[0] == "format":
            if len(words) < 2 or words[1] not in _FORMATS:
                raise fail(f"unsupported format line {line!r}")
            fmt = words[1]
        elif words[0] == "element":
            if element is not None:
                raise fail("only files with a single 'vertex' element are supported")
            element = words[1]
            if element != "vertex":
                raise fail(f"unsupported element {element!r}")
            count = int(words[2])
        elif words[0] == "property":
            if words[1] == "list" or words[1] not in _NUMPY_CODE_BY_PLY_TYPE:
                raise fail(f"unsupported property {line!r}")
            fields.append((words[2], words[1]))
    if fmt is None or count is None:
        raise fail("header lacks a format or a vertex element")
    order = _FORMATS[fmt]
    dtype = np.dtype([(name, order + _NUMPY_CODE_BY_PLY_TYPE[t]) for name, t in fields])
    return fmt, count, dtype, comments


def read_ply(path: str | os.PathLike) -> tuple[np.ndarray, list[str]]:
    """Vertex records (structured array, PLY field names) and header comments.

    Reads the files this module writes (binary or ascii, one vertex element,
    no list properties) without needing plyfile.
    """
    path = Path(path)
    with open(path, "rb") as f:
        fmt, count, dtype, comments = _parse_header(f, path)
        if fmt == "ascii":
            if count == 0:
                return np.empty(0, dtype=dtype), comments
            data = np.loadtxt(f, dtype=dtype, max_rows=count, ndmin=1)
        else:
            blob = f.read(count * dtype.itemsize)
            if len(blob) != count * dtype.itemsize:
                raise UserError(f"cannot read {path}: truncated, expected {count} vertices")
            data = np.frombuffer(blob, dtype=dtype, count=count).copy()
    if len(data) != count:
        raise UserError(f"cannot read {path}: truncated, expected {count} vertices, found {len(data)}")
    return data, comments
