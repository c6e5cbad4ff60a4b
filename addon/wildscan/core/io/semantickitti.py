"""SemanticKITTI's layout (numpy only): what its readers (semantic-kitti-api, Open3D-ML,
mmdetection3d) load unchanged.

    sequences/NN/velodyne/NNNNNN.bin   float32 x y z remission per point
    sequences/NN/echo/NNNNNN.npy       a realistic dataset scan's echo, echoes, label_purity, mixed
    sequences/NN/labels/NNNNNN.label   uint32 per point: class in the low 16 bits, instance in the high 16
    sequences/NN/rangeimage/NNNNNN.npz the scan on its native grid (core/rangeimage.py; datasets)
    sequences/NN/poses.txt             one line per scan: the 3x4 matrix taking its points to the world
    sequences/NN/calib.txt             P0..P3 and Tr (no cameras here: identities)
    labels.yaml                        label config in semantic-kitti-api's form

Remission is the point's intensity divided by 100, clipped to [0, 1] (KITTI's range): a
dataset's intensity is already in 0..100 (core/intensity.py: `physical`, or `class`, Table I's
15..100 becoming 0.15..1); a single realistic-model scan's echo energy exceeds 100 on bright
surfaces nearer than 10 m (core/echoes.py), whose remission saturates at 1 as a receiver
does (docs/formats.md "Intensity"). The instance is the element's rank among its world's
instance ids (1-based), so it fits 16 bits and is the same object across one sequence.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..label_schemes import LabelScheme
from .projection import Projection
from .rangeimage import npz_bytes, scan_range_image
from .writer import ScanFile, ScanOutput, Writer

REMISSION_SCALE = 0.01  # reflectivity (Table I) -> remission
MAX_INSTANCE = 0xFFFF


def remission(intensity: np.ndarray) -> np.ndarray:
    """float32 remission of intensities (0..100 -> 0..1, clipped to [0, 1]), as the .bin has it."""
    return np.clip(np.asarray(intensity, dtype=np.float64) * REMISSION_SCALE, 0.0, 1.0).astype(np.float32)


def scan_bytes(xyz: np.ndarray, intensity: np.ndarray) -> bytes:
    """A velodyne .bin: float32 (N, 4) x y z remission, little-endian."""
    out = np.empty((len(xyz), 4), dtype="<f4")
    out[:, :3] = xyz
    out[:, 3] = remission(intensity)
    return out.tobytes()


def label_bytes(labels: np.ndarray, instances: np.ndarray) -> bytes:
    """A .label: uint32 per point, class id in the low 16 bits and instance in the high 16."""
    labels = np.asarray(labels, dtype=np.uint32)
    instances = np.asarray(instances, dtype=np.uint32)
    if labels.size and labels.max() > 0xFFFF:
        raise ValueError("SemanticKITTI class ids must fit 16 bits")
    if instances.size and instances.max() > MAX_INSTANCE:
        raise ValueError("SemanticKITTI instance ids must fit 16 bits")
    return ((instances << np.uint32(16)) | labels).astype("<u4").tobytes()


def float_bytes(values: np.ndarray) -> bytes:
    """A per-point float32 side file (the `hag` folder), same order as the velodyne file."""
    return np.asarray(values, dtype="<f4").tobytes()


def instance_ranks(world_instances: np.ndarray, instances: np.ndarray) -> np.ndarray:
    """Each point's instance as its rank (1-based) among the world's sorted instance ids;
    0 stays 0 (an untagged surface)."""
    world = np.unique(np.asarray(world_instances, dtype=np.int64))
    world = world[world > 0]
    if len(world) > MAX_INSTANCE:
        raise ValueError(f"a world with {len(world)} instances does not fit SemanticKITTI's 16 bits")
    inst = np.asarray(instances, dtype=np.int64)
    rank = np.searchsorted(world, inst) + 1
    return np.where(inst > 0, rank, 0).astype(np.uint32)


def encode(scan: ScanOutput, paths: dict[str, Path]) -> dict[str, bytes]:
    """The format table's SemanticKITTI writer (formats.py): the velodyne .bin and the .label,
    and a dataset's `hag` and `rangeimage` files. Instances rank among the world's (the same
    object across a sequence), or among the scan's own when the world is not known (a single
    scan)."""
    cloud = scan.cloud
    world = cloud.instance if scan.world_instances is None else scan.world_instances
    ranks = instance_ranks(world, cloud.instance)
    labels = scan.labels.map(cloud.label)
    files = {
        "velodyne": scan_bytes(cloud.xyz, cloud.intensity),
        "labels": label_bytes(labels, ranks),
    }
    if scan.hag is not None:
        files["hag"] = float_bytes(scan.hag)
        files["rangeimage"] = range_image_bytes(scan, labels, ranks)
        if "echo" in cloud.extra:
            files["echo"] = echo_bytes(cloud.extra)
    return files


def range_image_bytes(scan: ScanOutput, labels: np.ndarray, instances: np.ndarray) -> bytes:
    """The scan's range image (core/rangeimage.py) as an .npz: the .bin's remission, and the
    `labels` and `instances` (per point) of its label file."""
    cloud = scan.cloud
    image = scan_range_image(
        cloud, scan.metadata, remission(cloud.intensity), labels, instances, scan.lost_cells
    )
    return npz_bytes(image)


# A realistic scan's echo fields beside its .bin (datasets): numpy structured records, one per
# point in the order of the velodyne file (core/pointcloud.py OPTIONAL_FIELDS says what each is)
ECHO_DTYPE = np.dtype([("echo", "u1"), ("echoes", "u1"), ("label_purity", "<f4"), ("mixed", "u1")])


def echo_bytes(extra: dict) -> bytes:
    """echo/NNNNNN.npy: the echo fields a SemanticKITTI user needs to drop mixed pixels."""
    from ..truth.groundtruth import npy_bytes

    out = np.zeros(len(extra["echo"]), dtype=ECHO_DTYPE)
    for name in ECHO_DTYPE.names:
        out[name] = extra[name]
    return npy_bytes(out)


WRITER = Writer(
    name="semantickitti",
    title="SemanticKITTI",
    writes="SemanticKITTI: velodyne .bin (x y z remission) + .label (SemanticKITTI class, instance)",
    files=(
        ScanFile("velodyne", ".bin", "velodyne"),
        ScanFile("labels", ".label", "labels"),
        ScanFile("hag", ".bin", "hag", ground_truth=True),
        ScanFile("rangeimage", ".npz", "rangeimage", ground_truth=True),
        ScanFile("echo", ".npy", "echo", ground_truth=True),  # realistic datasets only
    ),
    scan_labels="semantickitti",
    encode=encode,
)


def _matrix_line(matrix: np.ndarray) -> str:
    return " ".join(f"{v:.12e}" for v in np.asarray(matrix, dtype=np.float64)[:3, :4].ravel())


def poses_text(matrices: list[np.ndarray]) -> str:
    """poses.txt: one row-major 3x4 matrix per scan, in the order of the scan files."""
    return "".join(_matrix_line(m) + "\n" for m in matrices)


def calib_text(imu_to_velo: np.ndarray | None = None) -> str:
    """calib.txt: there are no cameras, so every projection is the identity and Tr (velodyne
    to camera frame) is the identity: poses.txt applies to the points directly. With an IMU,
    `Tr_imu_to_velo` (KITTI's name for it) takes IMU-frame coordinates to the scans' frame,
    in the same `KEY: 12 numbers` form semantic-kitti-api's parse_calibration reads."""
    eye = np.eye(4)
    lines = [f"{key}: {_matrix_line(eye)}\n" for key in ("P0", "P1", "P2", "P3", "Tr")]
    if imu_to_velo is not None:
        lines.append(f"Tr_imu_to_velo: {_matrix_line(imu_to_velo)}\n")
    return "".join(lines)


def _yaml_map(name: str, mapping: dict, value=lambda v: str(v)) -> list[str]:
    return [f"{name}:"] + [f"  {k}: {value(v)}" for k, v in sorted(mapping.items())]


def label_config_yaml(
    scheme: LabelScheme,
    content: dict[int, float],
    splits: dict[str, list[int]],
    title: str,
    particles: bool = False,
    projection: Projection | None = None,
    weights: dict[str, dict[int, float]] | None = None,
) -> str:
    """The label configuration in semantic-kitti-api's form (labels, color_map (BGR), content,
    learning_map, learning_map_inv, learning_ignore, split by sequence number); `particles`:
    the data has weather, so weather's particle class is listed (without: the bytes of before it);
    `weights` (core/class_weights.py, by learning-map id): `class_weights_<name>` tables after
    the split (without: the bytes of before them); `projection`: LaserScan's H, W, fov_up and
    fov_down for these scans (core/projection.py)."""
    t = scheme.config_tables(particles)
    lines = [f"# {title}", f"# label ids: {scheme.title}", f"name: {json.dumps(scheme.name)}"]
    lines += _yaml_map("labels", t["labels"], json.dumps)
    lines += _yaml_map("color_map", t["color_map"], lambda c: f"[{c[0]}, {c[1]}, {c[2]}]")
    lines += _yaml_map("content", {k: content.get(k, 0.0) for k in t["labels"]}, repr)
    lines += _yaml_map("learning_map", t["learning_map"])
    lines += _yaml_map("learning_map_inv", t["learning_map_inv"])
    lines += _yaml_map("learning_ignore", t["learning_ignore"], lambda b: "True" if b else "False")
    lines.append("split:")
    for key in ("train", "valid", "test"):
        lines.append(f"  {key}: [{', '.join(str(s) for s in splits.get(key, []))}]")
    if projection is not None:
        kept = f"{100 * projection.kept:.1f} % of an untilted scan's beams"
        lines.append(f"# semantic-kitti-api's LaserScan(project=True, **projection) keeps {kept}")
        lines += _yaml_map("projection", projection.to_dict())
    for name, table in (weights or {}).items():
        lines += _yaml_map(f"class_weights_{name}", table, lambda w: repr(float(f"{w:.6g}")))
    return "\n".join(lines) + "\n"
