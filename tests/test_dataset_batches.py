"""How a dataset run cuts its scans into tasks (app/dataset/engine.py) and counts its worlds
(app/cache/config.py)."""

from wildscan.app.cache.config import count_worlds
from wildscan.app.dataset.engine import make_batches, tail_parts


def test_one_task_a_world_and_the_last_world_in_parts_for_several_workers():
    pending = {seed: list(range(50)) for seed in range(20)}
    one = make_batches(pending, 1)
    assert [(b.seed, b.indices) for b in one] == [(seed, list(range(50))) for seed in range(20)]
    two = make_batches(pending, 2)
    assert [b.seed for b in two[:19]] == list(range(19)) and all(len(b.indices) == 50 for b in two[:19])
    tail = two[19:]
    assert len(tail) == tail_parts(2) == 4 and {b.seed for b in tail} == {19}
    assert [i for b in tail for i in b.indices] == list(range(50))  # every scan once, in order
    assert [b.order for b in two] == list(range(len(two)))  # submitted in this order


def test_a_world_smaller_than_its_parts_is_cut_no_finer_than_a_scan():
    batches = make_batches({0: [4, 7], 1: []}, 2)
    assert [(b.seed, b.indices) for b in batches] == [(0, [4]), (0, [7])]


def test_a_world_several_workers_loaded_counts_once_built_before_read():
    sources, warned = {}, []
    facts = [(3, "built"), (3, "cache"), (4, "cache"), (4, "memory"), (5, "cache"), (5, "built")]
    for seed, source in facts:
        counts = count_worlds(sources, seed, {"world_source": source, "cache_warnings": ["w"]}, warned.append)
    assert counts == {"built": 2, "cache": 1} and sources == {3: "built", 4: "cache", 5: "built"}
    assert warned == ["w"] * len(facts)
