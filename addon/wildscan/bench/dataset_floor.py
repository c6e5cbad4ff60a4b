"""`wildscan bench-dataset`'s floor, where a run's time went, and what a larger run on a Dask
cluster would take, from the figures its workers report (app/dataset/worker.py: casts,
scans, tiles built and read, the world's poses, each task's start and end).

The floor of a run with W workers is the work no scheduling can remove, shared out evenly:
(the casts + the tiles built, summed over the workers) / W. The wall time beside it says how
much the rest costs: everything a scan does around its cast (its world's tiles joined and a
ray caster built over them, labels, truth, files), the world's poses, and the workers' waits.

The cluster figures extrapolate the measured per-worker work on paper: every scan's work
(its busy worker-seconds, the poses' aside) divides over the machines' workers, and so do
the poses: a world's poses are placed once, by one task its scans wait on (app/dataset/engine.py
_place_poses, worker.world_poses_task), so a world's poses are one worker's work.
"""

from __future__ import annotations

from dataclasses import dataclass

CLUSTER_SCANS = 10_000
CLUSTER_MACHINES = (1, 2, 4, 8, 16)
WORKERS_PER_MACHINE = 2  # one per core of a machine like this one


@dataclass
class Work:
    """A run's work in worker-seconds, summed over its workers."""

    workers: int
    scans: int
    wall: float
    busy: float  # inside tasks
    idle: float  # without a task (timeline.py)
    casts: float
    scans_s: float  # inside scans (the casts and a scan's tiles within)
    poses: float  # the world's poses (an endless world's placement: its tiles within)
    tiles_built: int
    tiles_read: int
    build_s: float  # building tiles (while placing poses, and while scanning)
    read_s: float  # reading tiles from the world cache
    scan_build_s: float  # of build_s, inside scans
    scan_read_s: float
    client_poses: float = 0.0  # s before the workers: one world's poses placed once for them all

    @property
    def floor(self) -> float:
        return (self.casts + self.build_s) / max(1, self.workers)

    def lines(self) -> list[str]:
        """Where the busy worker-seconds went."""
        around = self.scans_s - self.casts - self.scan_build_s - self.scan_read_s
        other = self.busy - self.scans_s - self.poses
        pose_tiles = self.build_s - self.scan_build_s + self.read_s - self.scan_read_s
        return [
            f"{self.workers} worker(s): {self.busy:.1f} worker-s busy, {self.idle:.1f} s idle; "
            f"floor {self.floor:.1f} s (casts {self.casts:.1f} s + tile builds {self.build_s:.1f} s, "
            f"over {self.workers}), wall {self.wall:.1f} s = "
            f"{self.wall / max(self.floor, 1e-9):.2f}x the floor",
            f"    casts {self.casts:.1f} s ({self.casts / max(self.scans, 1) * 1e3:.0f} ms a scan)",
            f"    tiles: {self.tiles_built} built in {self.build_s:.1f} s, {self.tiles_read} read from the "
            f"cache in {self.read_s:.1f} s",
            f"    poses of the world (placement on its tiles, those tiles' builds and reads "
            f"{pose_tiles:.1f} s within): {self.poses:.1f} s",
            f"    scans around their casts (each scan's tiles joined, its ray caster built, labels, "
            f"truth, files): {around:.1f} s ({around / max(self.scans, 1) * 1e3:.0f} ms a scan)",
            f"    the rest of the tasks (batches' set-up, manifest rows): {other:.1f} s",
            f"    before the workers: the poses of the worlds several workers scan, placed once: "
            f"{self.client_poses:.1f} s of the wall time",
        ]


def work_of(row) -> Work:
    """A bench row's work (bench/dataset.py BenchRow)."""
    t = row.tiles
    busy = sum(end - start for _, start, end in row.tasks)
    return Work(
        workers=row.workers,
        scans=row.scans,
        wall=row.seconds,
        busy=busy,
        idle=row.idle.total if row.idle is not None else 0.0,
        casts=row.cast_seconds,
        scans_s=row.scan_seconds,
        poses=row.world_build_seconds,
        tiles_built=int(t.get("world_built", 0) + t.get("scans_built", 0)),
        tiles_read=int(t.get("world_read", 0) + t.get("scans_read", 0)),
        build_s=t.get("world_build_seconds", 0.0) + t.get("scans_build_seconds", 0.0),
        read_s=t.get("world_read_seconds", 0.0) + t.get("scans_read_seconds", 0.0),
        scan_build_s=t.get("scans_build_seconds", 0.0),
        scan_read_s=t.get("scans_read_seconds", 0.0),
        client_poses=getattr(row, "client_poses", 0.0),
    )


def cluster_lines(one: Work, worlds: int, scans: int = CLUSTER_SCANS) -> list[str]:
    """What `scans` scans would take on N machines of WORKERS_PER_MACHINE workers, from a
    1-worker cold run of `worlds` worlds, as many scans a world as it had (so its worlds
    scale with the scans): a scan's work divides over the workers; a world's poses are placed
    once, by one worker, so a worker places max(a world's poses, its share of all poses)."""
    per_scan = (one.busy - one.poses) / max(one.scans, 1)
    per_pose = (one.poses + one.client_poses) / max(one.scans, 1)
    per_world = max(1, one.scans // max(worlds, 1))
    floor_per_scan = (one.casts + one.scan_build_s) / max(one.scans, 1)  # the poses' tiles are the poses'
    floor_per_pose = (one.build_s - one.scan_build_s) / max(one.scans, 1)
    out = [
        f"{scans:,} scans ({scans // per_world:,} worlds of {per_world:,}) on a Dask cluster of N machines x "
        f"{WORKERS_PER_MACHINE} workers, extrapolated from the 1-worker cold run: {per_scan:.2f} worker-s a "
        f"scan (of which casts and tile builds {floor_per_scan:.2f} s), {per_pose:.2f} worker-s a pose "
        "placed; a world's poses placed once, by one worker (its scans wait on that task)",
    ]
    for machines in CLUSTER_MACHINES:
        workers = machines * WORKERS_PER_MACHINE
        placed = max(per_world, scans / workers)  # the poses a worker places
        poses_s, scans_s = per_pose * placed, per_scan * scans / workers
        floor = floor_per_pose * placed + floor_per_scan * scans / workers
        out.append(
            f"  N = {machines:>2}: {(poses_s + scans_s) / 60:7.1f} min (poses {poses_s / 60:.1f} min, scans "
            f"{scans_s / 60:.1f} min; floor {floor / 60:.1f} min)"
        )
    return out
