"""Scene geometry saved to a file and loaded again without Blender (numpy only).

Extract a scene once where Blender is (`extract.extract_scene()` of a user's .blend),
save it with `save_geometry`, and scan it anywhere with `load_geometry`: no `bpy`
needed to load it, and a scan of the loaded geometry gives the same bytes as a scan
of the extracted one (every array is stored bit for bit, the local origin and the
object names too).

The file is an uncompressed .npz (a zip of .npy arrays, so `numpy.load` opens it
too) with one JSON entry, `header.json`:

    {"format": "wildscan-scene-geometry", "version": 1, "wildscan_version": "...",
     "object_names": [...], "metadata": {...}}

then vertices.npy (<f8, V x 3), faces.npy (<i4, T x 3), class_id.npy (<i2, T),
instance.npy (<i4, T), object_index.npy (<i4, T), offset.npy (<f8, 3), always in
that order; version 2 adds reflectivity.npy (<f4, T: `wildscan_reflectivity` overrides,
nan where none) after them, written only when some object has an override, so other
files keep version 1 and their bytes. The same geometry and metadata always give the same bytes: fixed entry
order, timestamps and attributes, little-endian arrays, sorted JSON, no compression
(a deflate stream could differ between zlib versions). The file is written under a
temporary name and renamed into place, so a failed save leaves nothing.

Version 3 adds a world's ground cover (core/world/cover.py) as `cover_*.npy` entries after
the rest, with its grid's shape in the header's `cover_shape`; only a world with cover has them.
Version 4 adds reflectance.npy (<f4, T: `wildscan_reflectance`, nan where none) after the
arrays of version 2, written only when some object carries one.

`version` rises when the layout changes; a file from a newer WildScan is refused
with a message saying so, never misread.
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np

from .. import __version__
from ..core.classes import BY_ID, MAX_INSTANCE, WATER_ID
from ..core.errors import UserError
from ..core.io.files import atomic_outputs, check_input_file, check_output_path, write_durably
from .geometry import SceneGeometry

FORMAT = "wildscan-scene-geometry"
VERSION = 4  # the newest this reads; a file without reflectivity overrides is written as 1
SUFFIX = ".npz"
HEADER = "header.json"
# name, stored dtype, number of dimensions
ARRAYS = (
    ("vertices", "<f8", 2),
    ("faces", "<i4", 2),
    ("class_id", "<i2", 1),
    ("instance", "<i4", 1),
    ("object_index", "<i4", 1),
    ("offset", "<f8", 1),
)
OVERRIDES = ("reflectivity", "<f4", 1)  # version 2
REFLECTANCE = ("reflectance", "<f4", 1)  # version 4
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # the zip format's earliest date: no clock in the bytes
# A file of ours starts with a zip entry (PK\x03\x04) holding header.json, stored
# uncompressed, so its first bytes name the format even when the rest is lost.
_ZIP_ENTRY = b"PK\x03\x04"
_HEAD_BYTES = 4096
# What a truncated or altered zip raises while it is opened or read (CRC mismatch, a
# directory cut short, a flipped compression method, an entry that ends early).
_DAMAGE = (zipfile.BadZipFile, EOFError, NotImplementedError, zipfile.LargeZipFile)


def save_geometry(geometry: SceneGeometry, path, metadata: dict | None = None, setting: str = "out") -> Path:
    """Write `geometry` (and a JSON-serialisable `metadata` dict, e.g. the .blend it came
    from) to `path` (.npz), atomically; returns the resolved path. UserError when the
    path cannot be written or the metadata is not JSON."""
    out = check_output_path(path, SUFFIX, setting)
    data = geometry_file_bytes(geometry, metadata)
    with atomic_outputs(out) as (tmp,):
        write_durably(tmp, lambda f: f.write(data))
    return out


def geometry_file_bytes(geometry: SceneGeometry, metadata: dict | None = None) -> bytes:
    """The bytes `save_geometry` writes."""
    cover = geometry.cover.to_arrays() if geometry.cover is not None else {}
    own = not np.isnan(geometry.reflectance).all()  # version 4 has every entry of 2 and 3
    overrides = cover or own or not np.isnan(geometry.reflectivity).all()
    arrays = ARRAYS + ((OVERRIDES,) if overrides else ()) + ((REFLECTANCE,) if own else ())
    header = {
        "format": FORMAT,
        "version": 4 if own else 3 if cover else 2 if overrides else 1,
        "wildscan_version": __version__,
        "object_names": list(geometry.object_names),
        "metadata": metadata or {},
        **({"cover_shape": list(geometry.cover.shape)} if cover else {}),
    }
    try:
        header_text = json.dumps(header, sort_keys=True, indent=1, allow_nan=False) + "\n"
    except (TypeError, ValueError) as e:
        raise UserError(f"scene geometry metadata must be plain JSON values: {e}") from None
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as zf:
        _write_entry(zf, HEADER, header_text.encode("utf-8"))
        for name, dtype, _ in arrays:
            array = np.ascontiguousarray(getattr(geometry, name), dtype=dtype)
            npy = io.BytesIO()
            np.lib.format.write_array(npy, array, version=(1, 0), allow_pickle=False)
            _write_entry(zf, f"{name}.npy", npy.getvalue())
        for name, array in cover.items():
            npy = io.BytesIO()
            np.lib.format.write_array(npy, np.ascontiguousarray(array), version=(1, 0), allow_pickle=False)
            _write_entry(zf, f"{name}.npy", npy.getvalue())
    return buffer.getvalue()


def _write_entry(zf: zipfile.ZipFile, name: str, data: bytes) -> None:
    info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
    info.compress_type = zipfile.ZIP_STORED
    info.create_system = 3  # the same bytes on every platform (Windows would write 0)
    info.external_attr = 0o644 << 16
    zf.writestr(info, data)


def load_geometry(path, setting: str = "geometry") -> SceneGeometry:
    """The SceneGeometry saved at `path`; UserError naming `setting` and the file when it
    is missing, not a WildScan scene geometry file, damaged, or from a newer version."""
    return load_geometry_file(path, setting)[0]


def load_geometry_file(path, setting: str = "geometry") -> tuple[SceneGeometry, dict]:
    """(geometry, header) of the file at `path`; the header holds `metadata`,
    `object_names`, `wildscan_version` (of the writer), `format` and `version`."""
    path = check_input_file(path, (SUFFIX,), setting)

    def fail(why: str) -> UserError:
        return UserError(f"{path}: {why}", setting=setting)

    try:
        ours = _starts_like_a_geometry_file(path)
        with zipfile.ZipFile(path) as zf:
            header = _read_header(zf, fail)
            wanted = ARRAYS + ((OVERRIDES,) if header["version"] >= 2 else ())
            wanted += (REFLECTANCE,) if header["version"] >= 4 else ()
            arrays = {name: _read_array(zf, name, dtype, ndim, fail) for name, dtype, ndim in wanted}
            cover = _read_cover(zf, header, fail)
    except _DAMAGE as e:
        if ours:
            raise fail(f"{DAMAGED} ({e}); {SAVE_AGAIN}") from None
        raise fail(f"not a WildScan scene geometry file (save one with a {SUFFIX} name)") from None
    except OSError as e:
        raise fail(f"cannot read it ({e.strerror or e})") from None
    names = header.get("object_names")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise fail("its object names are damaged")
    index = arrays["object_index"]
    if names and len(index) and (index.min() < 0 or index.max() >= len(names)):
        raise fail("its triangles name objects that are not listed")
    _check_range(arrays["class_id"], "class_id", 0, max(BY_ID), fail, f"(class ids, {WATER_ID} water)")
    _check_range(arrays["instance"], "instance", 0, MAX_INSTANCE, fail, "(instance ids)")
    try:
        geometry = SceneGeometry(object_names=tuple(names), cover=cover, **arrays)
    except ValueError as e:
        raise fail(f"its arrays do not fit together ({e})") from None
    return geometry, header


def _read_cover(zf: zipfile.ZipFile, header: dict, fail):
    """The ground cover a version-3 file carries (None: none)."""
    shape = header.get("cover_shape")
    if shape is None:
        return None
    from ..core.world.cover import CoverGrid

    names = ("origin", "class", "height", "terrain_xs", "terrain_ys", "terrain_z")
    try:
        arrays = {}
        for n in names:
            with zf.open(f"cover_{n}.npy") as f:
                arrays[f"cover_{n}"] = np.lib.format.read_array(f, allow_pickle=False)
        return CoverGrid.from_arrays(arrays, tuple(int(v) for v in shape))
    except (KeyError, ValueError) as e:
        raise fail(f"its ground cover is damaged ({e}); {SAVE_AGAIN}") from None


DAMAGED = "the file is damaged or truncated"
SAVE_AGAIN = "save it again with `wildscan extract`"


def _starts_like_a_geometry_file(path: Path) -> bool:
    """Whether the file begins the way every geometry file WildScan writes does, so a
    zip error further on means damage (a cut copy, flipped bits), not a foreign file."""
    with open(path, "rb") as f:
        head = f.read(_HEAD_BYTES)
    return head.startswith(_ZIP_ENTRY) and FORMAT.encode() in head


def _check_range(values: np.ndarray, name: str, low: int, high: int, fail, what: str) -> None:
    """Refuse a file whose `name` array holds a value outside [low, high]: a scan would
    index tables with it (class ids) or store it in an unsigned PLY field (instances)."""
    bad = np.flatnonzero((values < low) | (values > high))
    if len(bad):
        raise fail(
            f"{name}.npy holds {int(values[bad[0]])} at triangle {int(bad[0])}; "
            f"allowed {low} to {high} {what}: the file is damaged or was not written by WildScan"
        )


def _read_header(zf: zipfile.ZipFile, fail) -> dict:
    try:
        header = json.loads(zf.read(HEADER).decode("utf-8"))
    except KeyError:
        raise fail("not a WildScan scene geometry file (no header.json)") from None
    except (UnicodeDecodeError, ValueError):
        raise fail("its header.json is damaged") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        found = header.get("format") if isinstance(header, dict) else None
        raise fail(f"not a WildScan scene geometry file (format {found!r}, expected {FORMAT!r})")
    version = header.get("version")
    if not isinstance(version, int) or version < 1:
        raise fail(f"unknown scene geometry file version {version!r}")
    if version > VERSION:
        raise fail(
            f"written by a newer WildScan ({header.get('wildscan_version')}, file version {version}); "
            f"this WildScan {__version__} reads version {VERSION}"
        )
    return header


def _read_array(zf: zipfile.ZipFile, name: str, dtype: str, ndim: int, fail) -> np.ndarray:
    try:
        with zf.open(f"{name}.npy") as f:
            array = np.lib.format.read_array(f, allow_pickle=False)
    except KeyError:
        raise fail(f"{name}.npy is missing: the file is damaged; {SAVE_AGAIN}") from None
    except ValueError as e:
        raise fail(f"{name}.npy is damaged ({e})") from None
    rows_of_three = ndim == 1 or array.shape[1:] == (3,)
    if array.dtype != np.dtype(dtype) or array.ndim != ndim or not rows_of_three:
        raise fail(
            f"{name}.npy holds {array.dtype} {array.shape}, not {np.dtype(dtype)} of {ndim} dimensions"
        )
    if name == "offset" and array.shape != (3,):
        raise fail(f"offset.npy holds {array.shape[0]} numbers, not 3")
    return array
