"""One crop of the world for a whole drive (app/drive/world.py `crop_along`): exactly the
triangles whose xy bounding box comes within the crop's reach of a point of the path."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.app.drive.world import CROP_STEP, _samples, _thinned, crop_along
from wildscan.raycast.geometry import from_triangles


def scattered_triangles(seed: int = 4):
    """Small triangles over 120 m x 120 m, and a few 30 m ones (terrain-sized)."""
    rng = np.random.default_rng(seed)
    small = rng.uniform(-60, 60, (20_000, 1, 3)) + rng.normal(0, 0.3, (20_000, 3, 3))
    large = rng.uniform(-60, 60, (20, 1, 3)) + rng.uniform(-15, 15, (20, 3, 3))
    tris = np.concatenate([small, large])
    return from_triangles(tris, np.ones(len(tris), dtype=int), np.arange(len(tris)))


def reference_keep(geometry, xy: np.ndarray, radius: float) -> np.ndarray:
    """Each triangle's box against every sample of the path, one triangle at a time."""
    samples = _samples(_thinned(xy, CROP_STEP / 2), CROP_STEP)
    reach = radius + CROP_STEP / 2
    corners = geometry.vertices[geometry.faces][:, :, :2]
    keep = np.zeros(geometry.triangle_count, dtype=bool)
    for t, box in enumerate(corners):
        lo, hi = box.min(axis=0), box.max(axis=0)
        gap = np.clip(samples, lo, hi) - samples
        keep[t] = np.any(gap[:, 0] * gap[:, 0] + gap[:, 1] * gap[:, 1] <= reach * reach)
    return keep


def test_the_crop_keeps_the_boxes_within_reach_of_the_path():
    geometry = scattered_triangles()
    s = np.linspace(0, 1, 400)
    xy = np.column_stack([-40 + 80 * s, 25 * np.sin(6 * s)])  # a winding 90 m path
    part = crop_along(geometry, xy, 8.0)
    keep = reference_keep(geometry, xy, 8.0)
    assert 0 < keep.sum() < geometry.triangle_count
    assert np.array_equal(np.sort(part.instance), np.flatnonzero(keep))
    assert np.array_equal(part.vertices[part.faces], geometry.vertices[geometry.faces][keep])


@pytest.mark.parametrize("stretch", [slice(30, 60), slice(45, 46)])
def test_a_seeds_world_made_near_the_path_crops_as_the_whole_world(stretch):
    """DriveWorld.crop makes triangles only of the elements near the path; the crop is the
    crop of the whole world's triangles, array for array (a stretch of the trail, and a robot
    standing still)."""
    from wildscan.app.drive import DriveRequest
    from wildscan.app.drive.world import drive_world
    from wildscan.raycast.from_plan import plan_geometry

    world = drive_world(DriveRequest(out="-", seed=1, detail="low"))
    xy = (
        world.trail[stretch]
        if stretch.stop - stretch.start > 1
        else np.repeat(world.trail[stretch], 5, axis=0)
    )
    whole = plan_geometry(world.plan)
    expected = crop_along(whole, xy, 16.0)
    made: list = []

    def counting(plan, keep=None):
        geometry = plan_geometry(plan, keep)
        made.append(geometry.triangle_count)
        return geometry

    import wildscan.raycast.from_plan as from_plan

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(from_plan, "plan_geometry", counting)
        part = world.crop(xy, 16.0)
    assert expected.triangle_count < made[0] < whole.triangle_count  # fewer made, more than kept
    for name in ("vertices", "faces", "class_id", "instance", "object_index", "reflectivity", "offset"):
        assert np.array_equal(getattr(part, name), getattr(expected, name), equal_nan=True), name
    assert part.object_names == expected.object_names and part.cover is expected.cover
