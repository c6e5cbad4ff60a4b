"""`wildscan dataset` speaks the options `wildscan scan` and `wildscan world` have: a
top-level `vegetation`, and in [sensor] the realistic model with its divergence, echoes and
echo separation (ranges drawn per scan; the bad values are in test_dataset.py's table). A
tiny realistic dataset on solid vegetation is read back with laspy (echoes as LAS return
numbers), our PLY reader and plyfile, and with the SemanticKITTI layout (x y z remission,
no echo fields); it resumes and verifies."""

from __future__ import annotations

import json

import laspy
import numpy as np
import plyfile
import pytest

from wildscan.app.dataset.draws import draw_sensor
from wildscan.app.dataset.spec import load_spec, spec_from_dict
from wildscan.core.io.ply import read_ply

from tests.helpers.dataset_helpers import manifest_rows, read_kitti_scan, wildscan

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

TINY_REALISTIC = """\
layout = "paper"
seeds = [1]
detail = "low"
vegetation = "solid"
scans_per_world = 2
split = { train = 1.0, val = 0.0, test = 0.0 }

[poses]
zones = { forest = 1 }

[sensor]
rh = 6.0
model = "realistic"
divergence = [3.0, 6.0]
echoes = 3
echo_separation = 0.25
"""
ECHO_FIELDS = ("echo", "echoes", "label_purity", "mixed")

# --------------------------------------------------------------------------- the spec


def test_the_new_keys_default_as_scan_and_world_do():
    spec = spec_from_dict({})
    assert spec.vegetation == "porous"
    s = spec.sensor
    assert (s.model, s.divergence, s.echoes, s.echo_separation) == ("paper", 4.4, 3, 0.3)
    assert s.noise is None  # the model's own noise, as `wildscan scan` without --noise
    sensor = draw_sensor(s, 0, 0)
    assert sensor.model == "paper" and sensor.fixed_noise == 0.015  # the paper scans of before


def test_sensor_takes_every_sensor_option_of_scan():
    from wildscan.app.dataset.spec import SENSOR_KEYS
    from wildscan.cli.options import SENSOR_OPTIONS

    assert set(SENSOR_KEYS) == {*SENSOR_OPTIONS, "frame"}
    spec = spec_from_dict({"sensor": {"model": "realistic", **{key: 1 for key in ("noise_seed", "echoes")}}})
    assert (spec.sensor.noise_seed, spec.sensor.echoes) == (1, 1)


def test_realistic_ranges_draw_per_scan_and_change_the_config_hash():
    spec = spec_from_dict(
        {"sensor": {"model": "realistic", "echoes": [1, 3], "divergence": [1.0, 5.0], "echo_separation": 0.5}}
    )
    draws = [draw_sensor(spec.sensor, 7, k) for k in range(30)]
    assert draws == [draw_sensor(spec.sensor, 7, k) for k in range(30)]
    assert {d.echoes for d in draws} == {1, 2, 3} and all(isinstance(d.echoes, int) for d in draws)
    assert all(1.0 <= d.divergence_mrad <= 5.0 and d.echo_separation == 0.5 for d in draws)
    assert all(d.realistic and d.fixed_noise is None for d in draws)  # the datasheet's noise
    base = spec_from_dict({}).config_hash()
    for change in ({"vegetation": "solid"}, {"sensor": {"model": "realistic"}}):
        assert spec_from_dict(change).config_hash() != base


# --------------------------------------------------------------------------- a tiny realistic dataset


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("realistic")
    (root / "spec.toml").write_text(TINY_REALISTIC)
    result = wildscan("dataset", str(root / "spec.toml"), "--out", str(root / "out"), "--workers", "1")
    assert result.returncode == 0, result.stderr
    assert "complete: 2 of 2 scans" in result.stdout
    return root / "out"


def scan_files(root, kind: str, suffix: str):
    return sorted((root / "sequences" / "00" / kind).glob(f"*.{suffix}"))


def test_the_manifest_records_the_model_and_the_draws(dataset):
    rows = manifest_rows(dataset)
    assert [r["status"] for r in rows] == ["ok", "ok"]
    for row in rows:
        s = row["sensor"]
        assert s["model"] == "realistic" and s["echoes"] == 3 and s["echo_separation"] == 0.25
        assert 3.0 <= s["divergence"] <= 6.0 and s["noise"] is None
        assert sum(row["echo_counts"]) == row["points"] and 0 < row["mixed_points"] < row["points"]
    assert rows[0]["sensor"]["divergence"] != rows[1]["sensor"]["divergence"]
    spec = json.loads((dataset / "dataset.json").read_text())["spec"]
    assert spec["vegetation"] == "solid" and spec["sensor"]["model"] == "realistic"
    card = (dataset / "CARD.md").read_text()
    assert "solid vegetation" in card and "realistic sensor model" in card
    assert "Echoes (realistic model): " in card and "mixed pixels" in card
    # the returns lost below the UTM-30LX-EW's detection limit: a count and shares in the card
    lost = [row["lost_returns"] for row in rows]
    assert all(0 < x["lost"] < x["weighed"] for x in lost)
    weighed, gone = sum(x["weighed"] for x in lost), sum(x["lost"] for x in lost)
    assert (
        f"{gone:,} of {weighed:,} echoes" in card and "by class: terrain" in card and "by incidence:" in card
    )


def test_the_range_images_mask_the_lost_returns(dataset):
    for image in sorted((dataset / "sequences" / "00" / "rangeimage").glob("*.npz")):
        arrays = np.load(image)
        lost, mask = arrays["lost"], arrays["mask"]
        assert lost.shape == mask.shape and lost.any()
        assert not (lost & mask).any()  # a lost cell holds no point


def test_the_worker_scans_the_solid_world_with_the_realistic_model(dataset):
    from wildscan.app.dataset.worker import build_world
    from wildscan.app.scan import scan_effects
    from wildscan.core.scan import run_scan

    spec = load_spec(dataset.parent / "spec.toml")
    assert spec.vegetation == "solid"
    context = build_world(spec, 1)  # the worker's world (it keeps no plan: its cover, its backend)
    choice = context.poses[0]
    sensor = draw_sensor(spec.sensor, 1, 0)
    effects = scan_effects(None, sensor, context.cover)  # the default biome's sward, as the worker
    # the world's seed: its surfaces' reflectances, which the detection step weighs, as the worker's
    result = run_scan(
        context.backend, choice.pose, sensor, "leveled", choice.z_start, None, effects, world_seed=1
    )
    records, _ = read_ply(scan_files(dataset, "ply", "ply")[0])
    np.testing.assert_array_equal(records["x"], result.cloud.xyz[:, 0].astype(np.float32))
    np.testing.assert_array_equal(records["echo"], result.cloud.extra["echo"])


def test_ply_and_las_carry_the_echo_fields_and_kitti_stays_xyz_remission(dataset):
    for ply, las_path, bin_path in zip(
        scan_files(dataset, "ply", "ply"),
        scan_files(dataset, "las", "las"),
        scan_files(dataset, "velodyne", "bin"),
        strict=True,
    ):
        records, _ = read_ply(ply)
        names = list(plyfile.PlyData.read(str(ply))["vertex"].data.dtype.names)
        assert names[-6:] == ["hag", "support", *ECHO_FIELDS]
        assert set(np.unique(records["echo"])) == {1, 2, 3}  # a forest returns several echoes a beam
        assert np.all(records["echo"] <= records["echoes"])
        las = laspy.read(las_path)
        np.testing.assert_array_equal(las.return_number, records["echo"])
        np.testing.assert_array_equal(las.number_of_returns, records["echoes"])
        np.testing.assert_array_equal(las.label_purity, records["label_purity"])
        np.testing.assert_array_equal(las.mixed, records["mixed"])
        assert records["mixed"].any() and (records["label_purity"] < 1).any()
        xyz, remission = read_kitti_scan(bin_path)
        assert len(xyz) == len(records) and bin_path.stat().st_size == 16 * len(records)
        assert remission.min() >= 0.0 and remission.max() <= 1.0
        np.testing.assert_allclose(remission, records["intensity"] / 100, rtol=1e-6)


def test_the_echo_sidecar_beside_each_bin_holds_the_echo_fields_point_for_point(dataset):
    bins = scan_files(dataset, "velodyne", "bin")
    for ply, bin_path in zip(scan_files(dataset, "ply", "ply"), bins, strict=True):
        sidecar = bin_path.parents[1] / "echo" / f"{bin_path.stem}.npy"
        echo = np.load(sidecar, allow_pickle=False)  # plain numpy, no WildScan import
        records, _ = read_ply(ply)
        xyz, _ = read_kitti_scan(bin_path)
        assert echo.dtype.names == ("echo", "echoes", "label_purity", "mixed") and len(echo) == len(xyz)
        for name in echo.dtype.names:
            np.testing.assert_array_equal(echo[name], records[name])
        # what the sidecar is for: dropping mixed pixels from the .bin leaves points on their surface
        assert 0 < echo["mixed"].sum() < len(echo) and np.all(echo["label_purity"][echo["mixed"] == 0] > 0)


def test_a_rerun_resumes_and_verify_checks_every_file(dataset, tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(TINY_REALISTIC)
    again = wildscan("dataset", str(spec), "--out", str(dataset), "--workers", "1")
    assert again.returncode == 0 and "wrote 0 scans" in again.stdout, again.stderr
    verify = wildscan("dataset", "--verify", str(dataset))
    assert verify.returncode == 0 and "match the manifest" in verify.stdout, verify.stderr
    other = tmp_path / "porous.toml"
    other.write_text(TINY_REALISTIC.replace('"solid"', '"porous"'))
    changed = wildscan("dataset", str(other), "--out", str(dataset), "--workers", "1")
    assert changed.returncode == 2  # another spec: a different config hash
