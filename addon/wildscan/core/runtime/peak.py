"""A process's own peak resident memory (stdlib only)."""

from __future__ import annotations

import resource


def peak_resident_bytes() -> int:
    """This process's own peak resident set: /proc/self/status VmHWM, the high-water mark of its
    address space since its exec. Not getrusage's ru_maxrss alone: on Linux that keeps the
    parent's high-water mark across fork and exec, so a worker or child started by a process
    that has scanned for minutes reports the parent's gigabytes, not its own. Elsewhere
    ru_maxrss (kilobytes on Linux, bytes on macOS: only Linux has VmHWM, so kilobytes here)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
