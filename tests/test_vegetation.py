"""Porous vegetation (the default) and solid vegetation (the paper's look), planned without
Blender: skeletons visible inside crowns, leaf clusters and blades sized for the sensor, three
distinct tree kinds, shared meshes, and the solid worlds exactly the old ones."""

import json
from pathlib import Path

import numpy as np
import pytest

from wildscan.core.classes import class_by_name
from wildscan.core.errors import UserError
from wildscan.core.world import STAGE_INSTANCE_BASE, STAGE_INSTANCE_BLOCK, plan_hash, plan_world
from wildscan.core.world.shapes.foliage import BLADE_WIDTH, LEAF_SIZE
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.select import make_backend

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

GOLDEN = Path(__file__).parent / "golden" / "worlds.json"
KINDS = ("conifer", "broadleaf", "birch")


@pytest.fixture(scope="module")
def porous():
    return plan_world(0, "default")


@pytest.fixture(scope="module")
def solid():
    return plan_world(0, "default", vegetation="solid")


def test_solid_vegetation_is_the_old_world_byte_for_byte():
    golden = json.loads(GOLDEN.read_text())
    for detail in ("low", "default", "high"):
        solid = plan_world(1, detail, vegetation="solid", biome="paper")  # the golden files' biome
        assert plan_hash(solid) == golden[f"1/{detail}/solid"], detail


def test_porous_is_the_default_and_vegetation_is_checked(porous):
    assert porous.vegetation == "porous" and porous.describe()["vegetation"] == "porous"
    with pytest.raises(UserError) as info:
        plan_world(0, "default", vegetation="leafy")
    assert info.value.setting == "vegetation"


def test_repeated_vegetation_shares_one_mesh_per_kind_and_variant(porous, solid):
    assert porous.counts()["meshes"] == solid.counts()["meshes"]
    used = {e.proto for e in porous.elements_of("treetop")}
    assert used == {f"tree_{k}{v}_crown" for k in KINDS for v in range(2)}
    assert porous.counts()["objects_by_class"]["treetop"] > 2 * len(used)


def test_bushes_and_grass_stand_where_they_stood_with_solid_vegetation(porous, solid):
    for stage in ("bushes", "grass"):
        a, b = porous.elements_of(stage=stage), solid.elements_of(stage=stage)
        assert [(e.name, e.location, e.yaw, e.scale, e.instance) for e in a] == [
            (e.name, e.location, e.yaw, e.scale, e.instance) for e in b
        ]


def test_every_tree_keeps_its_stages_instance_block(porous):
    base = STAGE_INSTANCE_BASE["trees"]
    ids = [e.instance for e in porous.elements_of(stage="trees")]
    assert len(set(ids)) == len(ids) and all(base < i < base + STAGE_INSTANCE_BLOCK for i in ids)


def crown_and_trunk(plan, key):
    return plan.prototypes[f"tree_{key}_crown"], plan.prototypes[f"tree_{key}_trunk"]


@pytest.mark.parametrize("kind", KINDS)
def test_crowns_are_separate_leaf_clusters_sized_against_the_beam_spacing(porous, kind):
    crown, _ = crown_and_trunk(porous, f"{kind}0")
    tris = crown.vertices[crown.faces]
    # no vertex is shared: clusters with gaps, not a closed shell
    assert len(np.unique(crown.faces)) == 3 * len(crown.faces)
    sides = np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2)
    # 0.75-1.25 x LEAF_SIZE: several beam spacings (4.4 cm at 10 m) across, so each is seen
    assert sides.min() >= 0.74 * LEAF_SIZE[kind] and sides.max() <= 1.26 * LEAF_SIZE[kind]
    assert LEAF_SIZE[kind] > 3 * 0.25 * np.pi / 180 * 10


def test_the_three_tree_kinds_stay_distinct(porous):
    def profile(kind):
        crown, _ = crown_and_trunk(porous, f"{kind}0")
        v = crown.vertices
        z0, z1 = v[:, 2].min(), v[:, 2].max()
        r = np.hypot(v[:, 0], v[:, 1])
        thirds = [
            r[(v[:, 2] >= z0 + k * (z1 - z0) / 3) & (v[:, 2] < z0 + (k + 1) * (z1 - z0) / 3)]
            for k in range(3)
        ]
        return [np.percentile(t, 90) for t in thirds], (z1 - z0), r.max()

    (c_low, c_mid, c_top), c_h, _ = profile("conifer")
    (b_low, b_mid, b_top), b_h, b_r = profile("broadleaf")
    (_, _, _), h_h, h_r = profile("birch")
    assert c_low > c_mid > c_top  # a cone: widest at its foot
    assert b_mid > b_low and b_mid > b_top  # round: widest in the middle
    assert 2 * b_r > 0.9 * b_h  # as wide as tall
    assert 2 * h_r < 0.75 * h_h  # a birch: a narrow spindle


def test_the_skeleton_is_visible_inside_the_crown(porous):
    """Horizontal rays into a crown meet branches (class trunk) among the leaves."""
    for kind in KINDS:
        crown, trunk = crown_and_trunk(porous, f"{kind}0")
        v = np.concatenate([crown.vertices[crown.faces], trunk.vertices[trunk.faces]])
        cls = np.r_[
            np.full(len(crown.faces), class_by_name("treetop").id),
            np.full(len(trunk.faces), class_by_name("trunk").id),
        ]
        backend = make_backend("auto", geometry=from_triangles(v, class_id=cls), notify=None)
        z0, z1 = crown.vertices[:, 2].min(), crown.vertices[:, 2].max()
        gy, gz = np.meshgrid(np.linspace(-1.5, 1.5, 60), np.linspace(z0, z1, 120))
        origins = np.stack([np.full(gy.size, -10.0), gy.ravel(), gz.ravel()], -1)
        hits = backend.cast(origins, np.tile([1.0, 0, 0], (len(origins), 1)), 30.0)
        trunk_hit = hits.hit & (hits.class_id == class_by_name("trunk").id)
        x = origins[:, 0] + hits.distance
        off_axis = np.hypot(x, origins[:, 1]) > 0.4  # a branch, not the stem
        assert trunk_hit[hits.hit].mean() > 0.02, kind  # the skeleton is seen through the leaves
        assert (trunk_hit & off_axis).sum() > 10, kind  # branches among them, inside the crown
        assert (~hits.hit).mean() > 0.05, kind  # and some rays pass the whole crown


def test_high_grass_is_separate_blades_and_bushes_are_not_closed(porous):
    blades = porous.prototypes["high_grass0"]
    assert len(np.unique(blades.faces)) == 3 * len(blades.faces) >= 30
    foot = blades.vertices[blades.faces][:, :2]
    width = np.linalg.norm(foot[:, 0] - foot[:, 1], axis=1)
    assert width.min() >= BLADE_WIDTH[0] - 1e-9 and width.max() <= BLADE_WIDTH[1] + 1e-9
    bush = porous.prototypes["bush0"]
    assert len(bush.faces) > 100
    edges = np.sort(
        np.concatenate([bush.faces[:, [0, 1]], bush.faces[:, [1, 2]], bush.faces[:, [2, 0]]]), axis=1
    )
    _, count = np.unique(edges, axis=0, return_counts=True)
    assert (count == 1).mean() > 0.5  # open: most edges border one triangle only


def test_the_forest_stands_closed_with_porous_vegetation(porous, solid):
    trees = [len(p.elements_of("trunk", zone="forest")) for p in (porous, solid)]
    assert trees[0] > 2 * trees[1]


def test_a_pose_right_at_a_trunk_is_rejected_the_sensor_would_stand_inside_it():
    """The four placement lasers land around a trunk; the column would run up inside it."""
    from wildscan.app.poses import plan_backend
    from wildscan.core.errors import PoseRejected
    from wildscan.core.placement import Pose, place

    plan = plan_world(0, "low")
    backend = plan_backend(plan)
    trunk = min(plan.elements_of("trunk", zone="forest"), key=lambda e: e.radius)
    x, y, _ = trunk.location
    with pytest.raises(PoseRejected, match="inside a trunk"):
        place(backend, Pose(x, y, 30.0))
