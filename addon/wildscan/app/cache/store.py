"""A content-addressed cache on disk: numpy arrays and JSON, shared by processes and runs.

An entry is one file, `DIR/<kind>-<key>.npz`, where `key` is the SHA-256 of everything the
entry is a pure function of (key.py). It is an uncompressed zip of `.npy` arrays after one
`entry.json` (so `numpy.load(path)` opens it like any .npz), laid out so a reader needs no
copy: every array's data starts on a 64-byte boundary of the file (a padding field in each
zip entry's header), and the reader reads the file once into one buffer and takes the arrays
as views of it (writable, 64-byte aligned in memory too). No pickle anywhere: `.npy` of plain dtypes and JSON.

Verified on read: the zip's comment, the last 64 bytes of the file, is the SHA-256 (hex) of
every byte before it. The reader hashes the file as it reads it; an entry whose digest
differs (a damaged disk block, a truncated copy, an edited byte) is never used: the caller
hears one line (`warnings`), the file is removed and the caller builds the entry again.

Safe under concurrent writers: an entry is written under a temporary name in DIR and renamed
into place (os.replace, atomic within one file system), so a reader sees no entry or a whole
one, never half of one. Two processes building the same entry write the same bytes (the
entry is a pure function of its key); the last rename wins and nothing is lost.

Size-capped: after each write, the least recently used entries (by modification time; a hit
touches its entry) are removed until the entries together fit under the cap. Only files
named like entries are counted or removed, so a cache directory shared with other files
loses none of them. A temporary file older than STALE_TEMP_SECONDS (a writer that was
killed) is removed too.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import struct
import tempfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FORMAT = "wildscan-cache-entry"
SUFFIX = ".npz"
ENTRY_JSON = "entry.json"
DIGEST_BYTES = 64  # the hex SHA-256 in the zip comment, the file's last bytes
ALIGN = 64  # bytes: where each array's data starts (numpy pads .npy headers to 64 too)
CHUNK = 4 << 20  # bytes read (and hashed) at a time: hashed while still in the CPU's cache
STALE_TEMP_SECONDS = 3600.0
TEMP_PREFIX = ".tmp-"
_PAD_FIELD = 0x5750  # zip extra-field id of our padding (unassigned in the zip specification)
_LOCAL_HEADER = struct.Struct("<IHHHHHIIIHH")  # a zip entry's local header (30 bytes)
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # no clock in the bytes: the same entry, the same file
_ENTRY_NAME = re.compile(r"^[a-z]+-[0-9a-f]{64}\.npz$")


@dataclass
class Entry:
    meta: dict  # the JSON the writer stored
    arrays: dict[str, np.ndarray]  # views of one buffer holding the whole file


@dataclass
class DiskCache:
    """Entries under `root`, at most `max_bytes` of them together. `warnings` collects one
    line per problem met (a damaged entry, a directory that cannot be written); the caller
    shows them."""

    root: Path
    max_bytes: int
    warnings: list[str] = field(default_factory=list)
    _writable: bool = True
    _said: set[str] = field(default_factory=set)  # warnings given once per process

    def path(self, kind: str, key: str) -> Path:
        return self.root / f"{kind}-{key}{SUFFIX}"

    # -- reading ------------------------------------------------------------------------

    def get(self, kind: str, key: str) -> Entry | None:
        """The entry of `key`, or None when there is none (or it was damaged: then removed,
        with a warning)."""
        path = self.path(kind, key)
        inode = None
        try:
            with open(path, "rb") as f:
                inode = os.fstat(f.fileno()).st_ino
                entry = read_entry(f, kind, key)
        except (FileNotFoundError, NotADirectoryError):
            return None  # not there (or no cache folder at all): a miss
        except DamagedEntry as e:
            self.warnings.append(f"cache entry {path.name} is damaged ({e}): built again")
            _remove_if_same(path, inode)
            return None
        except OSError as e:
            self._warn_once(
                f"cannot read the world cache in {self.root} ({e.strerror or e}): worlds are built"
            )
            return None
        try:
            os.utime(path)  # most recently used
        except OSError:
            pass  # evicted meanwhile, or a read-only cache: the entry read is whole anyway
        return entry

    # -- writing ------------------------------------------------------------------------

    def put(self, kind: str, key: str, meta: dict, arrays: dict[str, np.ndarray]) -> None:
        """Store an entry (atomically), then keep the cache under its cap. A cache that
        cannot be written warns once and is not written again; the run goes on."""
        if not self._writable:
            return
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self.root, prefix=TEMP_PREFIX, suffix=SUFFIX)
        except OSError as e:
            self._not_writable(e)
            return
        try:
            with os.fdopen(fd, "w+b") as f:
                os.fchmod(f.fileno(), 0o644)  # as any file written (mkstemp makes it private)
                write_entry(f, kind, key, meta, arrays)
            os.replace(tmp, self.path(kind, key))
        except OSError as e:
            _unlink(Path(tmp))
            self._not_writable(e)
            return
        self.evict(keep=self.path(kind, key))

    def _warn_once(self, line: str) -> None:
        if line not in self._said:
            self._said.add(line)
            self.warnings.append(line)

    def _not_writable(self, error: OSError) -> None:
        self._writable = False
        self._warn_once(
            f"cannot write the world cache in {self.root} ({error.strerror or error}): "
            "worlds are built but not kept"
        )

    def evict(self, keep: Path | None = None) -> None:
        """Remove the least recently used entries until the rest fit under max_bytes (the
        entry `keep`, just written, last of all), and stale temporary files."""
        entries = []
        now = time.time()
        try:
            names = os.listdir(self.root)
        except OSError:
            return
        for name in names:
            path = self.root / name
            try:
                st = path.stat()
            except OSError:
                continue  # removed meanwhile
            if _ENTRY_NAME.match(name):
                entries.append((path == keep, st.st_mtime, name, st.st_size))
            elif name.startswith(TEMP_PREFIX) and now - st.st_mtime > STALE_TEMP_SECONDS:
                _unlink(path)
        total = sum(e[3] for e in entries)
        for _, _, name, size in sorted(entries):  # not `keep` before `keep`; oldest first
            if total <= self.max_bytes:
                break
            _unlink(self.root / name)
            total -= size

    def entries_bytes(self) -> int:
        """Bytes of all entries now in the cache."""
        total = 0
        for name in os.listdir(self.root) if self.root.is_dir() else ():
            if _ENTRY_NAME.match(name):
                try:
                    total += (self.root / name).stat().st_size
                except OSError:
                    pass
        return total


class DamagedEntry(Exception):
    pass


def _unlink(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass  # gone already (another process evicted it), or not ours to remove


def _remove_if_same(path: Path, inode: int | None) -> None:
    """Remove a damaged entry, unless another process has renamed a whole one over it since
    it was opened (same inode: still the damaged file)."""
    try:
        if inode is not None and path.stat().st_ino == inode:
            path.unlink()
    except OSError:
        pass


# ---------------------------------------------------------------------------------------
# the file


class _HashingWriter:
    """A write-only, unseekable stream over a file that hashes what goes through it, so
    zipfile writes sequentially (data descriptors) and the digest needs no second read. The
    last DIGEST_BYTES written (the zip comment, where the digest goes) are left out of it."""

    def __init__(self, f):
        self.f = f
        self.position = 0
        self.sha = hashlib.sha256()
        self.tail = b""  # the last bytes written, not hashed yet

    def write(self, data) -> int:
        view = memoryview(data).cast("B")
        self.f.write(view)
        size = len(view)
        self.position += size
        if size >= DIGEST_BYTES:
            self.sha.update(self.tail)
            self.sha.update(view[: size - DIGEST_BYTES])
            self.tail = bytes(view[size - DIGEST_BYTES :])
        else:
            joined = self.tail + bytes(view)
            self.sha.update(joined[:-DIGEST_BYTES])
            self.tail = joined[-DIGEST_BYTES:]
        return size

    def tell(self) -> int:
        return self.position

    def flush(self) -> None:
        self.f.flush()


def write_entry(f, kind: str, key: str, meta: dict, arrays: dict[str, np.ndarray]) -> None:
    """Write an entry to the open (binary, seekable) file `f`."""
    header = {"format": FORMAT, "version": 1, "kind": kind, "key": key, "meta": meta}
    text = json.dumps(header, sort_keys=True, allow_nan=False).encode("utf-8")
    out = _HashingWriter(f)
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        zf.comment = b"0" * DIGEST_BYTES  # replaced by the digest below
        _write_member(zf, out, ENTRY_JSON, lambda dest: dest.write(text), len(text))
        for name, array in arrays.items():
            array = np.asarray(array, order="C")  # (ascontiguousarray makes a 0-d array 1-d)
            if array.dtype.hasobject:
                raise TypeError(f"{name}: object arrays are not cached")
            head = io.BytesIO()
            np.lib.format.write_array_header_1_0(head, np.lib.format.header_data_from_array_1_0(array))
            body = _npy_body(head.getvalue(), array)
            size = head.tell() + array.nbytes
            _write_member(zf, out, f"{name}.npy", body, size)
    if out.tail != b"0" * DIGEST_BYTES:  # the zip format ends with its comment
        raise ValueError("the zip comment is not at the end of the file")
    f.seek(out.position - DIGEST_BYTES)
    f.write(out.sha.hexdigest().encode("ascii"))


def _npy_body(head: bytes, array: np.ndarray):
    """What writes one .npy member: its header, then the array's bytes as they are in memory."""

    def body(dest) -> None:
        dest.write(head)
        dest.write(memoryview(array.reshape(-1)).cast("B"))

    return body


def _write_member(zf: zipfile.ZipFile, out: _HashingWriter, name: str, body, size: int) -> None:
    info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
    info.compress_type = zipfile.ZIP_STORED
    info.create_system = 3
    info.external_attr = 0o644 << 16
    info.file_size = size
    fixed = _LOCAL_HEADER.size + len(name.encode("utf-8")) + 4  # + the padding field's own header
    pad = -(out.tell() + fixed) % ALIGN
    info.extra = struct.pack("<HH", _PAD_FIELD, pad) + bytes(pad)
    with zf.open(info, "w") as dest:
        body(dest)


def read_entry(f, kind: str, key: str) -> Entry:
    """The entry in the open file `f`, checked against its digest and its key; DamagedEntry
    if anything does not hold."""
    size = os.fstat(f.fileno()).st_size
    if size < DIGEST_BYTES + 22:
        raise DamagedEntry(f"{size} bytes, too short")
    raw = np.empty(size + ALIGN, dtype=np.uint8)  # numpy's buffer, so the data is 64-byte aligned
    buf = raw[-raw.ctypes.data % ALIGN :][:size]
    view = memoryview(buf)
    sha = hashlib.sha256()
    hashed = size - DIGEST_BYTES
    done = 0
    while done < size:
        n = f.readinto(view[done : min(size, done + CHUNK)])
        if not n:
            raise DamagedEntry(f"ends after {done} of {size} bytes")
        sha.update(view[min(done, hashed) : min(done + n, hashed)])
        done += n
    if sha.hexdigest().encode("ascii") != bytes(view[hashed:]):
        raise DamagedEntry("its SHA-256 differs from the one stored with it")
    try:
        f.seek(0)
        with zipfile.ZipFile(f) as zf:  # the central directory, from this very (verified) file
            infos = zf.infolist()
        header = json.loads(bytes(_member(view, infos[0])))
        if header.get("format") != FORMAT or header.get("kind") != kind or header.get("key") != key:
            raise DamagedEntry("it is not the entry its name says")
        arrays = {i.filename[: -len(".npy")]: _array(buf, view, i) for i in infos[1:]}
    except (zipfile.BadZipFile, ValueError, KeyError, IndexError, struct.error) as e:
        raise DamagedEntry(f"unreadable: {e}") from None
    return Entry(header["meta"], arrays)


def _member_start(view: memoryview, info: zipfile.ZipInfo) -> int:
    fields = _LOCAL_HEADER.unpack(view[info.header_offset : info.header_offset + _LOCAL_HEADER.size])
    return info.header_offset + _LOCAL_HEADER.size + fields[-2] + fields[-1]


def _member(view: memoryview, info: zipfile.ZipInfo) -> memoryview:
    start = _member_start(view, info)
    return view[start : start + info.file_size]


def _array(buf: np.ndarray, view: memoryview, info: zipfile.ZipInfo) -> np.ndarray:
    """A .npy member as a view of the buffer (no copy)."""
    start = _member_start(view, info)
    head = io.BytesIO(bytes(view[start : start + min(info.file_size, 65536)]))
    version = np.lib.format.read_magic(head)
    if version != (1, 0):
        raise ValueError(f"{info.filename}: .npy version {version}")
    shape, fortran, dtype = np.lib.format.read_array_header_1_0(head)
    if dtype.hasobject or fortran:
        raise ValueError(f"{info.filename}: not a plain C-ordered array")
    count = int(np.prod(shape, dtype=np.int64))
    if head.tell() + count * dtype.itemsize != info.file_size:
        raise ValueError(f"{info.filename}: its size does not match its header")
    return np.frombuffer(buf, dtype, count, offset=start + head.tell()).reshape(shape)
