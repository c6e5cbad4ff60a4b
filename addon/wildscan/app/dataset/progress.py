"""Progress of a dataset run on stderr: a live bar (tqdm) with scans done, rate and ETA in a
terminal; in a log (not a terminal), a plain line every 10 % or every 30 s."""

from __future__ import annotations

import sys
import time

PLAIN_EVERY_S = 30.0


class ScanProgress:
    def __init__(self, total: int, done: int = 0, quiet: bool = False, stream=None):
        self.total, self.start_done, self.done = total, done, done
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.last_line = (self.t0, -1)
        self.bar = None
        if not quiet and self.stream.isatty():
            try:
                from tqdm import tqdm

                self.bar = tqdm(
                    total=total, initial=done, unit="scan", desc="dataset", file=self.stream, smoothing=0.1
                )
            except ImportError:
                self.bar = None

    def update(self, done: int) -> None:
        done = min(done, self.total)
        if self.quiet or done == self.done and self.bar is None:
            return
        if self.bar is not None:
            self.bar.update(done - self.done)
        self.done = done
        if self.bar is None:
            self._plain()

    def _plain(self) -> None:
        now = time.perf_counter()
        tenth = (10 * self.done) // max(1, self.total)
        last_t, last_tenth = self.last_line
        if tenth == last_tenth and now - last_t < PLAIN_EVERY_S and self.done < self.total:
            return
        self.last_line = (now, tenth)
        rate = (self.done - self.start_done) / max(now - self.t0, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        eta_text = f", ETA {eta:,.0f} s" if self.done < self.total and eta != float("inf") else ""
        self.stream.write(
            f"dataset: {self.done:,}/{self.total:,} scans ({100 * self.done // max(1, self.total)}%), "
            f"{rate:.1f} scans/s{eta_text}\n"
        )
        self.stream.flush()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
