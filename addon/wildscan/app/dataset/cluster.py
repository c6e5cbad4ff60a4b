"""Getting a Dask client that works, or one line saying why not.

A local cluster: a worker killed while the cluster starts (the OOM killer, a user's `kill`)
makes Dask's LocalCluster raise ("Nanny failed to start"), so the start is tried again, up
to CLUSTER_STARTS times; when every try fails the reason of the last one (the worker's
exception, or the signal that killed it) ends the run as RunFailed. Ctrl-C or SIGTERM
while it starts is held until the cluster is up or given up (a signal inside Dask's start
leaves a half-built cluster whose shutdown prints tracebacks at exit), then raised; the
worker processes are born with SIGINT blocked, so a terminal's Ctrl-C, which reaches the
whole process group, is answered by this process alone.

An existing scheduler: Dask's Client bounds only the TCP connect; a server that accepts and
then says nothing (or answers HTTP, which Dask reads as a frame of exabytes) hangs it or
kills it with a MemoryError. So the address is first asked who it is, the whole exchange
bounded by PROBE_SECONDS, and only a Dask scheduler gets a Client.
"""

from __future__ import annotations

import asyncio
import logging
import signal
import threading
from contextlib import contextmanager
from multiprocessing import resource_tracker

from ...core.errors import UserError
from ..interrupts import Terminated

CLUSTER_STARTS = 3
PROBE_SECONDS = 10.0
CONNECT_SHARE = 0.8  # of PROBE_SECONDS, for the TCP connection itself
CLIENT_TIMEOUT = "15s"


class RunFailed(Exception):
    """The job cannot go on for a reason that is not the user's (a task keeps killing workers,
    no worker can start, the scheduler went away)."""


# ---------------------------------------------------------------------------------------
# signals held while Dask starts


@contextmanager
def signals_held():
    """SIGINT and SIGTERM are noted inside the block (not raised), and the first one is
    raised as KeyboardInterrupt / Terminated when it ends (main thread only)."""
    noted: list[int] = []
    try:
        previous = {s: signal.signal(s, lambda signum, frame: noted.append(signum)) for s in _SIGNALS}
    except ValueError:  # not the main thread: signals are not ours to handle
        yield noted
        return
    try:
        yield noted
    finally:
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
    if noted:
        raise Terminated() if noted[0] == signal.SIGTERM else KeyboardInterrupt


_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def ctrl_c_kept_from_workers(noted: list[int]):
    """SIGINT blocked in this thread inside the block, and so in every thread Dask starts
    there (its event loop, the threads that spawn and later respawn worker processes) and in
    every worker process those spawn: a mask is inherited by threads and across fork and
    exec. A terminal's Ctrl-C reaches the whole process group; a worker's interpreter that
    gets it while still importing `site` prints a "Fatal Python error" traceback on the
    user's terminal, whatever the parent does. The parent still hears it: a SIGINT pending
    at the end is noted, then delivered to the noting handler when the mask is restored.
    The workers are stopped by their nannies when the cluster closes, never by the signal."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    # The first process multiprocessing starts also starts its resource tracker, and that
    # start ends by unblocking SIGINT in its thread (SIG_UNBLOCK, not a restore): started
    # here first, it is left alone later.
    resource_tracker.ensure_running()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if signal.SIGINT in signal.sigpending():
            noted.append(signal.SIGINT)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


# ---------------------------------------------------------------------------------------
# a local cluster


def start_local_cluster(make_cluster):
    """make_cluster() until it gives a cluster (CLUSTER_STARTS tries); RunFailed with the
    reason when none starts. A signal while starting closes what started, then raises."""
    reason = ""
    for _ in range(CLUSTER_STARTS):
        cluster = None
        deaths = _DeathNotes()
        with signals_held() as noted, deaths.listening():  # raises a noted signal as it ends
            with ctrl_c_kept_from_workers(noted):
                try:
                    cluster = make_cluster()
                except Exception as e:  # Dask raises RuntimeError around the worker's own error
                    reason = deaths.reason(e)
            if noted and cluster is not None:
                _close_quietly(cluster)
        if cluster is not None:
            return cluster
    raise RunFailed(f"no local Dask worker could start ({reason})")


def _close_quietly(cluster) -> None:
    try:
        cluster.close(timeout=10)
    except Exception:  # closing on the way out of a Ctrl-C: the signal is what the user sees
        pass


class _DeathNotes(logging.Handler):
    """What Dask's nanny logs when a worker process dies while starting (its exit code or
    signal: the only trace of a worker the OOM killer took)."""

    def __init__(self):
        super().__init__(logging.INFO)
        self.deaths: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        if text.startswith("Worker process ") and (" killed " in text or " exited " in text):
            self.deaths.append(text)

    @contextmanager
    def listening(self):
        logger = logging.getLogger("distributed.nanny")
        level = logger.level
        logger.addHandler(self)
        logger.setLevel(min(level or logging.INFO, logging.INFO))
        try:
            yield
        finally:
            logger.removeHandler(self)
            logger.setLevel(level)

    def reason(self, error: BaseException) -> str:
        root = root_cause(error)
        if self.deaths and isinstance(root, RuntimeError):  # Dask's own words: the death says more
            death = self.deaths[-1]
            return f"{death}{' (out of memory?)' if death.endswith('signal 9') else ''}"
        return f"{type(root).__name__}: {one_line(root)}"


def root_cause(error: BaseException) -> BaseException:
    """The first exception of a chain (Dask wraps a worker's error in its own)."""
    seen = {id(error)}
    while True:
        nxt = error.__cause__ or error.__context__
        if nxt is None or id(nxt) in seen:
            return error
        seen.add(id(nxt))
        error = nxt


def one_line(error: BaseException) -> str:
    return " ".join(str(error).split()) or type(error).__name__


# ---------------------------------------------------------------------------------------
# an existing scheduler


def connect_scheduler(address: str):
    """A Client of the Dask scheduler at `address`, or UserError naming the address and
    what answered there."""
    from distributed import Client

    probe_scheduler(address)
    try:
        return Client(address, timeout=CLIENT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as e:
        raise UserError(
            f"--scheduler {address}: cannot reach a Dask scheduler there ({one_line(e)})"
        ) from None


def probe_scheduler(address: str, seconds: float = PROBE_SECONDS) -> None:
    """Ask `address` who it is (Dask's `identity`); UserError unless a scheduler answers
    within `seconds`, connect, handshake and reply together."""
    from distributed.comm import connect  # imported before the clock starts: seconds, here

    where = f"--scheduler {address}"
    connected: list[bool] = []
    try:
        identity = asyncio.run(asyncio.wait_for(_identity(connect, address, seconds, connected), seconds))
    except (asyncio.TimeoutError, TimeoutError):
        raise _no_answer(where, seconds, connected) from None
    except ValueError as e:  # a malformed address
        raise UserError(f"{where}: not a Dask scheduler address ({one_line(e)})") from None
    except (OSError, EOFError) as e:
        cause = root_cause(e)
        if isinstance(cause, (asyncio.CancelledError, asyncio.TimeoutError, TimeoutError)):
            # Dask's connect ran out of its own time (it wraps the cancelled wait in an OSError)
            raise _no_answer(where, seconds, connected) from None
        raise UserError(f"{where}: cannot reach a Dask scheduler there ({one_line(cause)})") from None
    except Exception as e:  # its bytes were not Dask's protocol: HTTP read as a frame size, say
        raise UserError(
            f"{where}: what answers there is not a Dask scheduler (it does not speak Dask's "
            f"protocol: {type(e).__name__})"
        ) from None
    kind = identity.get("type") if isinstance(identity, dict) else None
    if kind != "Scheduler":
        raise UserError(
            f"{where}: what answers there is not a Dask scheduler (it says it is {kind or 'something else'})"
        )


def _no_answer(where: str, seconds: float, connected: list[bool]) -> UserError:
    """The error for an address where no Dask scheduler answered in time: nothing accepted the
    connection, or something did and said nothing a scheduler says."""
    if not connected:
        return UserError(f"{where}: cannot reach a Dask scheduler there (no connection within {seconds:g} s)")
    return UserError(
        f"{where}: something accepts connections there but did not answer as a Dask scheduler "
        f"within {seconds:g} s (is it the dashboard or another server?)"
    )


async def _identity(connect, address: str, seconds: float, connected: list[bool]):
    # Dask retries a refused connection until its timeout, then says why: that reason
    # (a shorter timeout) rather than the overall bound's
    comm = await connect(address, timeout=seconds * CONNECT_SHARE)
    connected.append(True)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()
