"""What a dataset worker spends on a world before its first scan, built (cold cache) and read
from the world cache (warm), step by step: part of `wildscan bench-dataset`.

The same steps a worker takes (app/cache/worlds.py, app/dataset/worker.py build_world), in
this process, on one world: cold, the plan, the triangles, the planes, padded triangles and
settling bands (one pass: raycast/sealing.py), the settling index, the rest (open ground,
standing ground, instances), writing the entry, the caster's upload, its BVH (built on the
first cast) and the poses (sampled with the placement check); warm, reading and verifying
the entry, unpacking it, the same upload and BVH (Embree cannot save a BVH: it is built
again from the cached padded triangles) and the poses read back. Wall and CPU seconds: on a
busy machine the CPU seconds say more.
"""

from __future__ import annotations

import sys
import tempfile

import numpy as np


def world_load_steps(spec, seed: int, cache_dir) -> tuple[dict[str, dict[str, tuple[float, float]]], int]:
    """({"cold": {step: (wall, cpu)}, "warm": {...}}, bytes of the world's cache entries) for
    world `seed` of `spec`, with an empty cache in `cache_dir` at the start."""
    from ..app.cache.config import cache_config, open_cache
    from ..app.cache.worlds import prepared_world, step, world_inputs, world_poses
    from ..raycast.embree_backend import EmbreeBackend

    cache = open_cache(cache_config(cache_dir))
    out = {}
    for label in ("cold", "warm"):
        world = prepared_world(world_inputs(seed, spec.detail, spec.vegetation, spec.biome), cache)
        steps = dict(world.timings)
        with step(steps, "caster upload"):
            backend = EmbreeBackend(world.geometry, settler=world.settler)
        with step(steps, "caster BVH (first cast)"):
            backend.cast(np.zeros(3), np.array([[0.0, 0.0, -1.0]]), 1.0)
        with step(steps, "poses" + (" (sampled)" if label == "cold" else " (read)")):
            world_poses(world, backend, spec.scans_per_world, spec.poses, cache)
        out[label] = steps
        del world, backend
    return out, cache.entries_bytes()


def print_world_load_steps(spec, seed: int, stream=None) -> dict:
    stream = stream or sys.stdout
    with tempfile.TemporaryDirectory(prefix="wildscan-bench-world-cache-") as folder:
        steps, size = world_load_steps(spec, seed, folder)
    stream.write(
        f"\nworld {seed} ({spec.detail} detail, {spec.vegetation} vegetation, {spec.biome} biome) before "
        f"its first scan, one worker, built (cold cache) and read from the world cache (warm; its "
        f"entries {size / 1e6:,.0f} MB):\n\n"
        "| step | cold wall s | cold CPU s | warm wall s | warm CPU s |\n|---|---:|---:|---:|---:|\n"
    )
    names = list(steps["cold"]) + [n for n in steps["warm"] if n not in steps["cold"]]
    for name in names:
        cells = [_cell(steps[label].get(name), k) for label in ("cold", "warm") for k in (0, 1)]
        stream.write(f"| {name} | {' | '.join(cells)} |\n")
    totals = [
        _cell(tuple(sum(v[k] for v in steps[label].values()) for k in (0, 1)), k)
        for label in ("cold", "warm")
        for k in (0, 1)
    ]
    stream.write(f"| **total** | {' | '.join(totals)} |\n")
    stream.flush()
    return steps


def _cell(value, k: int) -> str:
    return "" if value is None else f"{value[k]:.2f}"
