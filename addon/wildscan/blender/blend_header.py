"""Which Blender wrote a .blend file, read from its first bytes (no bpy needed).

A .blend file starts with "BLENDER" and then, up to Blender 4.x, one character for the
pointer size ("_" 32-bit, "-" 64-bit), one for the byte order ("v" little, "V" big) and
three digits of the version ("304": 3.4), 12 bytes in all. Blender 5.0 writes a longer
header: the header's size in two digits, "-", the header format in two digits, the byte
order and four digits of the version ("BLENDER17-01v0500", as bpy 5.0.1 saves it).
The file itself may be plain, gzip (Blender up to 2.9x) or zstd compressed (3.0 on).

Blender says only "not a blend file" when a file is too new for it; this names the Blender
that wrote it so the message can say what to do.
"""

from __future__ import annotations

import io
import re
import zlib

HEADER_BYTES = 17  # the longest header (5.0's)
_READ = 1 << 20  # compressed bytes read to reach the header: the first zstd block is at most 128 KiB
_GZIP, _ZSTD = b"\x1f\x8b", b"\x28\xb5\x2f\xfd"
_HEADER = re.compile(rb"BLENDER(?:[_-][vV](\d{3})|\d\d-\d\d[vV](\d{4}))")


def blend_version(path) -> tuple[int, int] | None:
    """(major, minor) of the Blender that wrote the .blend at `path`, or None when its
    header cannot be read (not a .blend, damaged, or compressed with no zstd reader here)."""
    try:
        return header_version(first_bytes(path))
    except (OSError, EOFError, ValueError, zlib.error):
        return None


def header_version(head: bytes | None) -> tuple[int, int] | None:
    """(major, minor) from a .blend's uncompressed first bytes: "304" -> (3, 4), "0500" -> (5, 0)."""
    match = _HEADER.match(head or b"")
    if match is None:
        return None
    number = int(match.group(1) or match.group(2))
    return number // 100, number % 100


def first_bytes(path, count: int = HEADER_BYTES) -> bytes | None:
    """The first `count` bytes of the file once uncompressed; None when it is zstd and no
    zstd reader is at hand."""
    with open(path, "rb") as f:
        data = f.read(_READ)
    if data.startswith(_GZIP):
        return zlib.decompressobj(wbits=31).decompress(data, count)  # 31: a gzip wrapper
    if data.startswith(_ZSTD):
        return _unzstd(data, count)
    return data[:count]


def _unzstd(data: bytes, count: int) -> bytes | None:
    """The bpy wheel brings the zstandard module; a Blender's own Python may lack it, but
    Blender links libzstd, which ctypes reaches."""
    try:
        import zstandard
    except ImportError:
        return _unzstd_with_libzstd(data, count)
    try:
        return zstandard.ZstdDecompressor().stream_reader(io.BytesIO(data)).read(count)
    except zstandard.ZstdError:
        return None


def _unzstd_with_libzstd(data: bytes, count: int) -> bytes | None:
    import ctypes
    import ctypes.util

    try:
        lib = ctypes.CDLL(ctypes.util.find_library("zstd") or "libzstd.so.1")
    except OSError:
        return None

    class Buffer(ctypes.Structure):  # ZSTD_inBuffer / ZSTD_outBuffer: pointer, size, position
        _fields_ = [("ptr", ctypes.c_void_p), ("size", ctypes.c_size_t), ("pos", ctypes.c_size_t)]

    lib.ZSTD_createDStream.restype = ctypes.c_void_p
    lib.ZSTD_freeDStream.argtypes = [ctypes.c_void_p]
    lib.ZSTD_decompressStream.argtypes = [ctypes.c_void_p, ctypes.POINTER(Buffer), ctypes.POINTER(Buffer)]
    lib.ZSTD_decompressStream.restype = ctypes.c_size_t
    lib.ZSTD_isError.argtypes = [ctypes.c_size_t]
    lib.ZSTD_isError.restype = ctypes.c_uint
    source, target = ctypes.create_string_buffer(data, len(data)), ctypes.create_string_buffer(count)
    given = Buffer(ctypes.cast(source, ctypes.c_void_p), len(data), 0)
    taken = Buffer(ctypes.cast(target, ctypes.c_void_p), count, 0)
    stream = lib.ZSTD_createDStream()
    try:
        while taken.pos < count and given.pos < given.size:
            left = lib.ZSTD_decompressStream(stream, ctypes.byref(taken), ctypes.byref(given))
            if lib.ZSTD_isError(left):
                return None
            if left == 0:  # the frame ended
                break
    finally:
        lib.ZSTD_freeDStream(stream)
    return target.raw[: taken.pos]
