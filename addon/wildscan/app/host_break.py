"""A Ctrl-C that Debian's Blender took before our handler was installed (stdlib only).

`blender -b [file.blend] -P script.py` installs its own SIGINT handler as it starts
(creator_signals.c, sig_handle_blender_esc): the first Ctrl-C prints "Sent an internal
break event" and only sets `G.is_break`, the second exits 2. Until the script runs (Blender's
start-up and the .blend's loading, about a second) a Ctrl-C reaches that handler, not ours,
and Blender has no Python API for the flag, so the scan would be written and the run exit 0.

`break_flag_reader()` finds the flag from the handler itself, while it is still installed:
in the x86-64 builds checked (Debian's Blender 3.4.1) its first two instructions are
`lea rax, [rip + G]` (48 8d 05 disp32) and `mov byte [rax + offsetof(Global, is_break)], 1`
(c6 80 disp32 01). Anything else (another build, another CPU, no C handler: the bpy wheel,
whose SIGINT is Python's own) gives None and nothing is read.
"""

from __future__ import annotations

import ctypes
import platform
import signal
import struct
import sys
from collections.abc import Callable

LEA_RAX_RIP = b"\x48\x8d\x05"  # lea rax, [rip + disp32]
MOV_BYTE_RAX = b"\xc6\x80"  # mov byte [rax + disp32], imm8


class _Sigaction(ctypes.Structure):
    """glibc's struct sigaction on Linux x86-64 (bits/sigaction.h): handler, 1024-bit mask,
    flags, restorer."""

    _fields_ = [
        ("handler", ctypes.c_void_p),
        ("mask", ctypes.c_ulong * 16),
        ("flags", ctypes.c_int),
        ("restorer", ctypes.c_void_p),
    ]


def break_flag_reader() -> Callable[[], bool] | None:
    """A function telling whether Blender's G.is_break is set, or None (module doc). Call it
    before replacing the SIGINT handler."""
    if not sys.platform.startswith("linux") or platform.machine() not in ("x86_64", "AMD64"):
        return None
    if signal.getsignal(signal.SIGINT) is not None:  # a Python handler: not Blender's binary
        return None
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        current = _Sigaction()
        if libc.sigaction(signal.SIGINT, None, ctypes.byref(current)) != 0 or not current.handler:
            return None
        address = _flag_address(current.handler, ctypes.string_at(current.handler, 14))
    except (OSError, AttributeError, ValueError):
        return None
    if address is None:
        return None
    flag = ctypes.c_ubyte.from_address(address)
    return lambda: bool(flag.value)


def _flag_address(handler: int, code: bytes) -> int | None:
    """The address `mov byte [rax + d2], 1` writes after `lea rax, [rip + d1]`, or None when
    the handler's code is not that."""
    if len(code) < 14 or code[:3] != LEA_RAX_RIP or code[7:9] != MOV_BYTE_RAX or code[13] != 1:
        return None
    (base,) = struct.unpack("<i", code[3:7])
    (offset,) = struct.unpack("<i", code[9:13])
    return handler + 7 + base + offset
