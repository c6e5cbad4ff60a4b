"""The classes a file lists (core/classes.py listed_classes): one answer from what the points
carry and what the scan's effects declare, read by every writer, so a PLY header and its JSON
sidecar list the same classes, for a scan and for a drive."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from wildscan.core.classes import GROUND_IDS, LABELS, LOG, LOG_ID, PARTICLE_ID, listed_classes
from wildscan.core.effects import CLEAR_AIR, Effects, Weather
from wildscan.core.io.ply import read_ply, write_scan_files
from wildscan.core.pointcloud import PointCloud

REQUIRED = [c.id for c in LABELS if not c.optional]


def header_ids(ply) -> list[int]:
    _, comments = read_ply(ply)
    return [int(c.split()[1]) for c in comments if c.startswith("class ")]


def sidecar_ids(ply) -> list[int]:
    return [row["id"] for row in json.loads(ply.with_suffix(".json").read_text())["classes"]]


def cloud_of(labels) -> PointCloud:
    n = len(labels)
    return PointCloud(
        xyz=np.zeros((n, 3), np.float32),
        intensity=np.zeros(n, np.float32),
        label=np.asarray(labels, np.uint16),
        instance=np.zeros(n, np.uint32),
        ring=np.zeros(n, np.uint16),
        sweep=np.zeros(n, np.uint16),
        range=np.ones(n, np.float32),
    )


def test_optional_classes_are_listed_where_declared_or_carried_in_id_order():
    assert [c.id for c in listed_classes()] == REQUIRED == list(range(13))
    assert {c.id for c in LABELS if c.optional} == {LOG_ID, PARTICLE_ID, *GROUND_IDS}
    assert [c.id for c in listed_classes(declared=(PARTICLE_ID,))] == [*REQUIRED, PARTICLE_ID]
    assert [c.id for c in listed_classes([2, PARTICLE_ID, LOG_ID], ())] == [*REQUIRED, LOG_ID, PARTICLE_ID]
    assert listed_classes([LOG_ID], (LOG_ID,))[-1] is LOG


def test_effects_declare_what_they_can_produce():
    weather = Weather.of({"rain": 10.0}, 0)
    assert CLEAR_AIR.classes == () and Effects((weather,)).classes == (PARTICLE_ID,)


@pytest.mark.parametrize(
    "labels, declared, listed",
    [
        ([1, 2], (), REQUIRED),  # a clear paper scan: the table of before the optional classes
        ([1, LOG_ID], (), [*REQUIRED, LOG_ID]),  # a point carries one the metadata omits
        ([1, 2], (PARTICLE_ID,), [*REQUIRED, PARTICLE_ID]),  # declared, no point carries it
    ],
)
def test_a_ply_header_and_its_sidecar_list_the_same_classes(tmp_path, labels, declared, listed):
    from wildscan.core.classes import class_table_dict

    meta = {"classes": class_table_dict(listed_classes(declared=declared))}
    ply, _ = write_scan_files(tmp_path / "scan.ply", cloud_of(labels), meta)
    assert header_ids(ply) == sidecar_ids(ply) == listed


@pytest.mark.slow
def test_a_scan_and_a_drive_over_ground_cover_list_the_same_classes_in_header_and_sidecar(tmp_path):
    """The default biome covers the ground and has deadwood (its cover effect declares `log`):
    every file lists it, whether or not a point of that scan is one (a drive's sidecar once
    left it out while its header listed it)."""
    from wildscan.app.drive import DriveRequest, run_drive
    from wildscan.core.sensors import SensorConfig

    from tests.test_cover import scan
    from tests.test_drive_outputs import SEED, _limited

    result = scan("mixed", "forest", frame="leveled")
    ply, _ = write_scan_files(tmp_path / "scan.ply", result.cloud, result.metadata)
    assert header_ids(ply) == sidecar_ids(ply) == [*REQUIRED, LOG_ID]

    out = tmp_path / "drive"
    request = DriveRequest(out=str(out), seed=SEED, detail="low", trail=True, sensor=SensorConfig(rh_deg=6.0))
    run_drive(replace(_limited(request, out), scans=None), say=lambda text: None)
    plys = sorted(out.rglob("*.ply"))
    assert len(plys) >= 2
    for path in plys:
        assert header_ids(path) == sidecar_ids(path) == [*REQUIRED, LOG_ID], path
