"""`wildscan dataset`: make (or finish) a dataset, and verify one.

A run locks the output folder, removes what a killed run left (temporary files only),
re-checks the scans already in the manifest (size and SHA-256: a changed file is scanned
again), submits the missing scans to Dask and records each batch as it returns. Whatever
stops it - Ctrl-C, SIGTERM, SIGKILL, a dead worker, a full disk - the manifest lists only
complete scans whose files are all in place, and the same command finishes the job with
the bytes one uninterrupted run would have written.
"""

from __future__ import annotations

import hashlib
import os
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from ...core.class_weights import class_weights, learning_counts, weights_json
from ...core.errors import UserError, shortened
from ...core.io import semantickitti as sk
from ...core.io.files import atomic_outputs, output_directory, write_durably
from ...core.label_schemes import scheme
from ...core.runtime.pause import pause_here
from ...core.runtime.signals import check_lost_signal, deferred, on_signal, signal_pending
from ..cache.config import count_worlds
from ..interrupts import Interrupted, Terminated, raise_terminated
from . import card
from .classes import dataset_classes
from .cluster import RunFailed, probe_scheduler
from .engine import Batch, Engine, make_batches
from .layout import LABELS_YAML, WEIGHTS_JSON, remove_temp_files, sequence_files
from .lock import lock, unlock
from .manifest import Manifest, broken_rows
from .progress import ScanProgress
from .revisits import REVISITS_JSON, revisits_text
from .scan_names import scan_names
from .spec import DatasetSpec


@dataclass
class RunReport:
    root: Path
    planned: int
    ok: int
    failed: int
    written: int  # scans this run recorded in the manifest (each with its files, or its reason)
    seconds: float
    complete: bool
    engine: str
    before: int = 0  # scans the manifest held (and that were re-checked) when the run began
    without_pose: int = 0  # of `written`, the scans recorded without a valid pose (no files)
    peak_rss: dict[int, int] = field(default_factory=dict)  # worker pid -> peak resident bytes
    world_build_seconds: float = 0.0
    scan_seconds: float = 0.0  # summed over workers: inside their scans, and the cast within
    cast_seconds: float = 0.0
    tiles: dict[str, float] = field(default_factory=dict)  # worker.tile_facts, summed over tasks
    client_poses_seconds: float = 0.0  # poses placed before the workers (land.poses_before_the_workers)
    bpy_imported: bool = False  # whether any worker had imported bpy (it never should)
    worlds: dict[str, int] = field(default_factory=dict)  # "built" / "cache" -> worlds a worker loaded so
    world_sources: dict[int, str] = field(default_factory=dict)  # seed -> "built" / "cache"
    started: float = 0.0  # wall clock when the engine began (timeline.py)
    tasks: list[tuple[int, float, float]] = field(default_factory=list)  # (pid, start, end) per task
    scans: list[tuple[str, int]] = field(default_factory=list)  # (sequence, scan) this run wrote, in order


# ---------------------------------------------------------------------------------------
# the output folder


def check_same_spec(root: Path, existing: dict | None, manifest: Manifest, spec: DatasetSpec) -> None:
    wanted = spec.config_hash()
    hashes = {r["config_hash"] for r in manifest.rows.values()} | (
        {existing["config_hash"]} if existing else set()
    )
    changed = _changed_device_files(existing, spec)
    if hashes - {wanted} and changed:
        raise UserError(
            f"--out {root} was begun with other contents of the device file {changed[0]} (edited since "
            "the dataset's first scans: its scans would mix two sensors); put the file back as it was, "
            "or give another --out for the new sensor"
        )
    if hashes - {wanted}:
        raise UserError(
            f"--out {root} holds a dataset of another spec or WildScan version (config hash "
            f"{sorted(hashes - {wanted})[0][:12]}, this spec {wanted[:12]}); give another --out or that spec"
        )
    if existing is None and not manifest.rows:
        strays = [p.name for p in root.iterdir() if not p.name.startswith(".")]
        if strays:
            raise UserError(
                f"--out {root} is not empty and holds no WildScan dataset (it has {strays[0]}, ...)"
            )


def spec_device_files(spec: DatasetSpec) -> dict[str, str]:
    from .devices import device_files

    return device_files(spec.sensor.device)


def _changed_device_files(existing: dict | None, spec: DatasetSpec) -> list[str]:
    """The device files whose contents differ from the run that began the dataset (the same
    spec otherwise), so the refusal can name the file rather than a hash."""
    if not existing or existing.get("spec") != spec.to_dict() or "device_files" not in existing:
        return []
    was, now = existing["device_files"], spec_device_files(spec)
    return sorted(path for path in now if was.get(path) != now[path])


# ---------------------------------------------------------------------------------------
# the run


@dataclass
class _State:
    spec: DatasetSpec
    root: Path
    manifest: Manifest
    existing: dict | None
    files: dict[str, dict] = field(default_factory=dict)
    runs: list[dict] = field(default_factory=list)

    def world_rows(self, seed: int) -> list[dict] | None:
        """The rows of a world in scan order, or None while any is missing."""
        seq = self.spec.sequence_of(seed)
        rows = [self.manifest.rows.get((seq, i)) for i in range(self.spec.scans_per_world)]
        return None if any(r is None for r in rows) else rows

    def write_text(self, rel: str, text: str) -> None:
        data = text.encode("utf-8")
        with atomic_outputs(self.root / rel) as (tmp,):
            write_durably(tmp, lambda f: f.write(data))
        self.files[rel] = {"path": rel, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}

    def write_sequence_files(self, seed: int) -> None:
        rows = self.world_rows(seed)
        if rows is None or "semantickitti" not in self.spec.formats:
            return
        import numpy as np

        paths = sequence_files(self.spec.sequence_of(seed))
        poses = [np.array(r["pose_matrix"]).reshape(3, 4) for r in rows if r["status"] == "ok"]
        self.write_text(paths["poses"], sk.poses_text(poses))
        self.write_text(paths["calib"], sk.calib_text())

    def dataset_json(self, complete: bool) -> dict:
        spec = self.spec
        splits = spec.splits()
        return {
            "format": card.FORMAT,
            "config_hash": spec.config_hash(),
            "spec": spec.to_dict(),
            **({"device_files": files} if (files := spec_device_files(spec)) else {}),
            "versions": card.versions(),
            "sequences": [
                {"sequence": spec.sequence_of(s), "seed": s, "split": splits[s]} for s in spec.seeds
            ],
            "complete": complete,
            "totals": card.totals(spec, self.manifest),
            "files": dict(sorted(self.files.items())),
            "runs": self.runs,
        }

    def save(self, complete: bool = False) -> dict:
        data = self.dataset_json(complete)
        card.write_dataset_json(self.root, data)
        return data


def run_dataset(
    spec: DatasetSpec,
    out,
    workers: int | None = None,
    scheduler: str | None = None,
    limit: int | None = None,
    quiet: bool = False,
    say=print,
    warn=None,
    cache: dict | None = None,
) -> RunReport:
    """Make or finish the dataset of `spec` in `out`; `say` gets notes for stdout, `warn` a
    warning (default: one line on stderr). `cache`: the world cache the workers keep built
    worlds in (app/cache/config.py cache_config; None: none)."""
    if scheduler:  # before anything is written: a wrong address is the user's to fix
        probe_scheduler(scheduler)
    _check_finishable(spec)
    root = output_directory(out, "--out")
    fd = lock(root)
    try:
        return _run_locked(spec, root, workers, scheduler, limit, quiet, say, warn or _warn, cache)
    finally:
        unlock(root, fd)


def _check_finishable(spec: DatasetSpec) -> None:
    """What finalize derives from the spec alone (labels.yaml's projection over every device
    the spec may draw), derived before any scan: a spec it cannot describe fails now, not
    after its last scan."""
    from .projection import dataset_projection

    dataset_projection(spec)


def _warn(text: str) -> None:
    sys.stderr.write(f"wildscan dataset: warning: {text}\n")


def _run_locked(spec, root, workers, scheduler, limit, quiet, say, warn, cache=None) -> RunReport:
    existing = card.read_dataset_json(root)
    manifest = Manifest.load(root)
    check_same_spec(root, existing, manifest, spec)
    warning = spec.empty_split_warning()
    if warning:  # after the checks: a refused run says one line only
        warn(warning)
    remove_temp_files(root)
    broken = broken_rows(manifest)
    for key, problem in sorted(broken.items()):
        say(f"scan {key[1]} of sequence {key[0]} will be written again: {problem}")
        manifest.drop(key)
    if broken:
        manifest.write()
    state = _State(spec, root, manifest, existing)
    if existing:
        state.files = dict(existing.get("files", {}))
        state.runs = list(existing.get("runs", []))
    pending = _pending(spec, manifest, limit)
    report = RunReport(
        root, len(spec.seeds) * spec.scans_per_world, 0, 0, 0, 0.0, False, _engine_name(workers, scheduler)
    )
    report.before = len(manifest.rows)
    try:
        state.save()  # complete: false until finalize has written the card
        engine = Engine(workers, scheduler, cache=cache)
        if scheduler is None and any(pending.values()):  # the workers share this machine's world cache
            from .land import poses_before_the_workers

            seeds, count = [seed for seed, todo in pending.items() if todo], workers or os.cpu_count() or 1
            news = None if quiet else say
            report.client_poses_seconds = poses_before_the_workers(spec, seeds, count, cache, news)
        stop = _run_engine(state, pending, engine, quiet, report, warn) if any(pending.values()) else None
        report.seconds += report.client_poses_seconds  # the run's time: its poses placed first included
        _finish(state, report, stop)
    except (KeyboardInterrupt, Terminated) as signal_:  # one landing between the steps above
        raise _stopped(STOPPED[type(signal_)], state, report) from None
    return report


def _engine_name(workers, scheduler) -> str:
    if scheduler:
        return f"scheduler {scheduler}"
    return f"local, {workers or os.cpu_count() or 1} workers"


def _pending(spec: DatasetSpec, manifest: Manifest, limit: int | None) -> dict[int, list[int]]:
    pending, budget = {}, limit if limit is not None else float("inf")
    for seed in spec.seeds:
        seq = spec.sequence_of(seed)
        todo = [i for i in range(spec.scans_per_world) if (seq, i) not in manifest.rows]
        todo = todo[: int(max(0, min(budget, len(todo))))]
        budget -= len(todo)
        pending[seed] = todo
    return pending


def _run_engine(state: _State, pending, engine: Engine, quiet, report: RunReport, warn=_warn) -> None:
    recorded = len(state.manifest.rows)
    progress = ScanProgress(report.planned, recorded, quiet)
    in_flight: dict[str, int] = {}
    t0 = time.perf_counter()
    report.started = time.time()

    def on_batch(batch: Batch, result: dict) -> None:
        for row in result["rows"]:
            state.manifest.add(row)
            if row["status"] == "ok":
                report.scans.append((row["sequence"], int(row["scan"])))
        state.manifest.write()
        report.written += len(result["rows"])
        report.without_pose += sum(1 for row in result["rows"] if row["status"] != "ok")
        in_flight.pop(batch.label, None)
        facts = result["worker"]
        report.peak_rss[facts["pid"]] = max(report.peak_rss.get(facts["pid"], 0), facts["peak_rss_bytes"])
        report.world_build_seconds += facts["world_build_seconds"]
        report.scan_seconds += facts.get("scan_seconds", 0.0)
        report.cast_seconds += facts.get("cast_seconds", 0.0)
        for name, value in facts.get("tiles", {}).items():
            report.tiles[name] = report.tiles.get(name, 0) + value
        report.bpy_imported |= facts["bpy_imported"]
        report.worlds = count_worlds(report.world_sources, batch.seed, facts, warn)
        if "task" in facts:
            report.tasks.append((facts["pid"], *facts["task"]))
        if state.world_rows(batch.seed) is not None:
            state.write_sequence_files(batch.seed)
            state.save()

    def on_poll() -> None:
        check_lost_signal()  # a Ctrl-C Python dropped in a finaliser stops the run here
        ticking = sum(min(n, in_flight.get(k, 0)) for k, n in engine.ticks.items())
        progress.update(len(state.manifest.rows) + ticking)

    stop: tuple[str, int] | None = None
    failure: Exception | None = None
    previous = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        engine.start()
        batches = make_batches(pending, engine.worker_count())
        for b in batches:
            b.label = f"wildscan-{engine.token}-{b.seed}-{b.indices[0]}"
            in_flight[b.label] = len(b.indices)
        engine.run(state.spec.to_dict(), str(state.root), batches, on_batch, on_poll)
    except KeyboardInterrupt:
        stop = STOPPED[KeyboardInterrupt]
    except Terminated:
        stop = STOPPED[Terminated]
    except (UserError, RunFailed) as e:
        failure = e
    finally:  # a bug's traceback too leaves no worker running and no temporary file
        _stop_engine(engine, progress, state, previous)
    report.seconds = time.perf_counter() - t0
    if failure is not None:
        raise type(failure)(f"{failure}; {_written_text(state, report)}; rerun the same command to continue")
    state.runs.append(_run_record(report))
    return stop


STOPPED = {KeyboardInterrupt: ("interrupted", 130), Terminated: ("terminated", 143)}


def _finish(state: _State, report: RunReport, stop: tuple[str, int] | None) -> None:
    """finalize; then the stop that ended the scans (or one that cut finalize) as Interrupted,
    saying what is in the manifest."""
    try:
        finalize(state, report)
    except (KeyboardInterrupt, Terminated) as signal_:
        stop = stop or STOPPED[type(signal_)]
    except (UserError, RunFailed):
        raise
    except Exception as e:  # a bug: one line saying what is safe (the scans), not a traceback
        raise RunFailed(
            f"finishing the dataset (labels.yaml, weights.json, the card) failed: {type(e).__name__}: "
            f"{shortened(str(e))}; {_written_text(state, report)}, all kept. This is a bug in WildScan: "
            "please report this line"
        ) from e
    if stop is not None:
        raise _stopped(stop, state, report)


def _stopped(stop: tuple[str, int], state: _State, report: RunReport) -> Interrupted:
    """What a stopped run says: the scans it completed (counted and named), never the
    bookkeeping files it rewrote."""
    return Interrupted(
        f"{stop[0]}: {_written_text(state, report)}; the same command finishes the job", stop[1]
    )


def _stop_engine(engine: Engine, progress: ScanProgress, state: _State, previous) -> None:
    """Close the cluster and remove debris whatever happens: a second Ctrl-C (a user who
    pressed twice) is noted and raised once this is done, never left to cut it short."""
    signal.signal(signal.SIGTERM, on_signal)  # deferred below like SIGINT (cli.dispatch's)
    try:
        with deferred():
            pause_here("stopping", until=signal_pending)
            engine.close()
            progress.close()
            # The local workers are gone, and remote ones lost their scheduler: a temporary
            # file is debris (a remote worker still finishing a scan renames its own or,
            # finding it gone, drops the scan: atomic_outputs).
            remove_temp_files(state.root)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _written_text(state: _State, report: RunReport) -> str:
    """What the manifest holds and where it came from (this run, or runs before it)."""
    rows = len(state.manifest.rows)
    named = f": {scan_names(report.scans)}" if report.scans else ""
    parts = [f"{report.written - report.without_pose:,} written by this run{named}"]
    if report.without_pose:
        parts.append(f"{report.without_pose:,} more without a valid pose")
    if report.before:
        parts.append(f"{report.before:,} from before")
    return f"{rows:,} of {report.planned:,} scans in the manifest ({', '.join(parts)})"


def _run_record(report: RunReport) -> dict:
    return {
        "engine": report.engine,
        "scans_written": report.written,
        "seconds": round(report.seconds, 3),
        "scans_per_second": round(report.written / report.seconds, 3) if report.seconds > 0 else 0.0,
        "world_build_seconds": round(report.world_build_seconds, 3),
        "peak_rss_bytes_per_worker": sorted(report.peak_rss.values()),
        "bpy_imported_by_a_worker": report.bpy_imported,
        "worlds_from_cache": report.worlds.get("cache", 0),
        "worlds_built": report.worlds.get("built", 0),
    }


def finalize(state: _State, report: RunReport) -> None:
    """Sequence files of complete worlds, the label config, dataset.json and the card."""
    spec = state.spec
    for seed in spec.seeds:  # written again each time: cheap, and repairs a changed one
        state.write_sequence_files(seed)
    worlds = {spec.sequence_of(seed): state.world_rows(seed) for seed in spec.seeds}
    state.write_text(REVISITS_JSON, revisits_text({k: v for k, v in worlds.items() if v is not None}))
    complete = all(state.world_rows(seed) is not None for seed in spec.seeds)
    totals = card.totals(spec, state.manifest)
    counts = _learning_counts(spec, totals)
    state.write_text(LABELS_YAML, _labels_yaml(spec, totals, class_weights(counts)))
    state.write_text(WEIGHTS_JSON, weights_json(scheme(spec.label_scheme), counts, _classes(spec, totals)))
    state.save(complete=False)  # every file above listed, should the card never come
    data = state.dataset_json(complete)
    # The card before dataset.json: a run stopped between them leaves `complete: false`
    # (from the run's start), never a complete dataset without its card.
    card.write_card(state.root, spec, data)
    card.write_dataset_json(state.root, data)
    report.ok, report.failed, report.complete = totals["scans_ok"], totals["scans_failed"], complete


def _raw_counts(spec: DatasetSpec, totals: dict) -> dict[int, int]:
    """Points per raw label id of the spec's label scheme."""
    from ...core.classes import BY_ID

    s = scheme(spec.label_scheme)
    by_name = {c.name: c.id for c in BY_ID.values()}
    out: dict[int, int] = {}
    for name, n in totals["class_points"].items():
        raw = s.from_wildscan[by_name[name]]
        out[raw] = out.get(raw, 0) + n
    return out


def _learning_counts(spec: DatasetSpec, totals: dict) -> dict[int, int]:
    return learning_counts(scheme(spec.label_scheme), _raw_counts(spec, totals), _classes(spec, totals))


def _classes(spec: DatasetSpec, totals: dict):
    return dataset_classes(spec.weather, spec.biome, totals["class_points"])


def _labels_yaml(spec: DatasetSpec, totals: dict, weights: dict) -> str:
    from .projection import dataset_projection

    s = scheme(spec.label_scheme)
    points = max(1, totals["points"])
    content = {raw: n / points for raw, n in _raw_counts(spec, totals).items()}
    splits = spec.splits()
    by_split = {"train": [], "valid": [], "test": []}
    for seed in spec.seeds:
        by_split[{"val": "valid"}.get(splits[seed], splits[seed])].append(int(spec.sequence_of(seed)))
    title = f"WildScan dataset, config {spec.config_hash()[:16]}"
    projection = dataset_projection(spec)
    return sk.label_config_yaml(s, content, by_split, title, _classes(spec, totals), projection, weights)
