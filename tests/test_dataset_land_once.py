"""An endless world's poses are placed once a run, by one task whose result every scan task of
the world is handed (app/dataset/engine.py Engine._place_poses, worker.py world_poses_task): on
one worker, on two local workers and on a Dask scheduler the run's tasks place them once, the
poses are land_poses' own, and the scans are the same bytes whichever way they ran."""

from __future__ import annotations

from pathlib import Path

import pytest

from wildscan.app.dataset.spec import spec_from_dict

pytestmark = pytest.mark.slow  # a Dask cluster a run: tens of seconds

# one small world without a cache: a worker that places the poses itself says "built"
SPEC = {
    "seeds": [1],
    "scans_per_world": 6,
    "detail": "low",
    "formats": ["semantickitti"],
    "split": {"train": 1.0},
    "poses": {"region": [-100, -100, 100, 100], "min_scans_with": {}},
    "sensor": {"rh": 4.0, "max_range": 10.0},
}


def _run(engine, out: Path) -> list[dict]:
    """Every task's result of one run of SPEC's scans on `engine`, in the order they ended."""
    from wildscan.app.dataset.engine import make_batches

    spec = spec_from_dict(SPEC)
    out.mkdir(parents=True)
    results = []
    try:
        engine.start()
        batches = make_batches({1: list(range(spec.scans_per_world))}, engine.worker_count())
        for b in batches:
            b.label = f"wildscan-{engine.token}-{b.seed}-{b.indices[0]}"
        engine.run(spec.to_dict(), str(out), batches, lambda b, r: results.append(r), lambda: None)
    finally:
        engine.close()
    return results


def _files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory):
    from wildscan.app.dataset.engine import Engine

    out = tmp_path_factory.mktemp("one") / "out"
    return out, _run(Engine(workers=1), out)


def _placed_once(results: list[dict]) -> list:
    """The poses the run's tasks were handed, after checking that exactly one task placed them
    (its world "built": no cache here) and the scan tasks took them (none placed its own)."""
    built = [r for r in results if r["worker"]["world_source"] == "built"]
    assert len(built) == 1 and "poses" in built[0], [r["worker"]["world_source"] for r in results]
    assert sum(len(r["rows"]) for r in results) == SPEC["scans_per_world"]
    return built[0]["poses"]


def test_one_worker_places_the_poses_once_and_they_are_land_poses_own(one_worker):
    from wildscan.app.cache.worlds import pose_to_json
    from wildscan.app.dataset.land import land_poses

    _, results = one_worker
    expected, _ = land_poses(spec_from_dict(SPEC), 1)
    assert _placed_once(results) == [pose_to_json(p) for p in expected]


def test_two_local_workers_place_a_world_s_poses_once_and_scan_the_same_bytes(one_worker, tmp_path):
    from wildscan.app.dataset.engine import Engine

    out, results = one_worker
    two = _run(Engine(workers=2), tmp_path / "out")
    assert len(two) >= 4  # the world cut in tail parts: both workers scan it
    assert len({r["worker"]["pid"] for r in two}) == 2
    assert _placed_once(two) == _placed_once(results)
    assert _files(tmp_path / "out") == _files(out)


def test_a_dask_scheduler_s_workers_place_them_once_too(one_worker, tmp_path):
    from distributed import LocalCluster

    from wildscan.app.dataset.engine import Engine

    out, results = one_worker
    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        scheduler_kwargs={"dashboard_address": None},
    ) as cluster:
        two = _run(Engine(scheduler=cluster.scheduler_address), tmp_path / "out")
    assert _placed_once(two) == _placed_once(results)
    assert _files(tmp_path / "out") == _files(out)
