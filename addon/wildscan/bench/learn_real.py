"""`wildscan bench --suite learn TRAIN_DIR --test REAL_DIR --scheme NAME`: train the learn
suite's baseline (bench/learn.py: the same features, sampling and model) on a WildScan
dataset and score it on a folder of real scans in their dataset's own layout, beside the
same model trained on part of the real folder (the ceiling).

Real folders are found by their layout (the first that has scans with labels):

    semantickitti  sequences/NN/velodyne/NNNNNN.bin + sequences/NN/labels/NNNNNN.label
    rellis3d       SEQ/os1_cloud_node_kitti_bin/NNNNNN.bin +
                   SEQ/os1_cloud_node_semantickitti_label_id/NNNNNN.label (RELLIS-3D's README)
    goose          lidar/SPLIT/SCENE/NAME_vls128.bin (GOOSE-Ex: NAME_pcl.bin) +
                   labels/SPLIT/SCENE/NAME_goose.label (goose-dataset.de "dataset structure")
    wildscenes     TRAVERSE/Clouds/NAME.bin (float32 x y z) + TRAVERSE/Labels/NAME.label (int32
                   ids) (csiro-robotics/WildScenes scripts/visualisation/view_cloud.py)

A .bin of the first three is float32 x y z remission; a .label uint32 with the class in its
low 16 bits (SemanticKITTI's). Labels go through the scheme's learning map (labels.yaml's);
an id the scheme does not list counts as ignored.

The WildScan dataset's labels are mapped to the scheme's learning ids: as they are when the
dataset was written in that scheme, through the scheme's table (core/label_schemes.py) when it
was written in WildScan's own ids. Every scan of it trains (its splits are WildScan worlds, not
the real data). The real scans are sorted by path; the later half (at least one) is scored,
the earlier half trains the ceiling: consecutive scans of a sequence look alike, so an
interleaved split would flatter the ceiling. Scored: the classes both the WildScan training
points and the real test points have (the categories both share), per class IoU on the real
test points, WildScan-trained beside real-trained.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..core.rng import stage_rng
from .learn import (
    fit_predict,
    open_dataset,
    read_scan,
    scan_rotation,
    test_sample,
    train_per_class,
    train_sample,
    velodyne_files,
)
from .learn_features import scan_features


@dataclass(frozen=True)
class RealLayout:
    name: str
    clouds: str  # glob of the point files under the folder
    columns: int  # float32 values a point: 4 (x y z remission) or 3 (x y z)
    label_dtype: str

    def label_for(self, cloud: Path) -> Path:
        if self.name == "semantickitti":
            return cloud.parent.parent / "labels" / f"{cloud.stem}.label"
        if self.name == "rellis3d":
            return cloud.parent.parent / "os1_cloud_node_semantickitti_label_id" / f"{cloud.stem}.label"
        if self.name == "goose":  # lidar/SPLIT/SCENE/NAME_vls128.bin -> labels/SPLIT/SCENE/NAME_goose.label
            base = cloud.name.rsplit("_", 1)[0]
            scene, split = cloud.parent, cloud.parent.parent
            return split.parent.parent / "labels" / split.name / scene.name / f"{base}_goose.label"
        return cloud.parent.parent / "Labels" / f"{cloud.stem}.label"  # wildscenes


LAYOUTS = (
    RealLayout("semantickitti", "sequences/*/velodyne/*.bin", 4, "<u4"),
    RealLayout("rellis3d", "*/os1_cloud_node_kitti_bin/*.bin", 4, "<u4"),
    RealLayout("goose", "lidar/*/*/*.bin", 4, "<u4"),
    RealLayout("wildscenes", "**/Clouds/*.bin", 3, "<i4"),
)


def find_real_scans(root: Path) -> tuple[RealLayout, list[tuple[Path, Path]]]:
    """The layout of the folder `root` and its (points, labels) pairs sorted by path, or a
    UserError naming the layouts looked for."""
    root = Path(root)
    if not root.is_dir():
        raise UserError(f"{root} is not a folder", setting="test")
    for layout in LAYOUTS:
        pairs = [(c, layout.label_for(c)) for c in sorted(root.glob(layout.clouds))]
        pairs = [(c, lab) for c, lab in pairs if lab.is_file()]
        if pairs:
            return layout, pairs
    looked = "; ".join(f"{lay.name}: {lay.clouds}" for lay in LAYOUTS)
    raise UserError(f"{root} holds no labelled scans in a layout the suite reads ({looked})", setting="test")


def read_real_scan(layout: RealLayout, cloud: Path, label: Path):
    """(xyz, remission or None, raw label ids) of one real scan; UserError when the two files
    do not hold the same number of points."""
    values = np.fromfile(cloud, dtype="<f4")
    raw = np.fromfile(label, dtype=layout.label_dtype).astype(np.int64) & 0xFFFF
    if values.size % layout.columns or values.size // layout.columns != raw.size:
        raise UserError(
            f"{cloud} ({values.size} float32 values, {layout.columns} a point) and {label} ({raw.size} "
            "labels) do not hold the same points",
            setting="test",
        )
    points = values.reshape(-1, layout.columns)
    return points[:, :3], (points[:, 3] if layout.columns == 4 else None), raw


@dataclass(frozen=True)
class Target:
    """A label scheme's learning ids: raw id -> learning id (ignored where unknown)."""

    lookup: np.ndarray  # raw id (0..65535) -> learning id
    ignored: frozenset[int]
    names: dict[int, str]


def target_of(scheme_name: str) -> Target:
    from ..core.label_schemes import scheme

    s = scheme(scheme_name)
    ignore_id = next((x for x, ign in s.learning_ignore.items() if ign), 0)
    lookup = np.full(1 << 16, ignore_id, dtype=np.int64)
    for raw, xid in s.learning_map.items():
        lookup[raw] = xid
    ignored = frozenset(x for x, ign in s.learning_ignore.items() if ign)
    names = {xid: s.labels[raw] for xid, raw in s.learning_map_inv.items()}
    return Target(lookup, ignored, names)


def wildscan_to_target(dataset_scheme: str, scheme_name: str, target: Target) -> np.ndarray:
    """Raw id of the WildScan dataset's labels -> the target's learning id."""
    from ..core.label_schemes import scheme

    if dataset_scheme == scheme_name:
        return target.lookup
    if dataset_scheme != "wildscan":
        raise UserError(
            f"the WildScan dataset's labels are in {dataset_scheme}'s ids, which do not map to "
            f'{scheme_name}\'s: write it with label_scheme = "wildscan" or "{scheme_name}"',
            setting="scheme",
        )
    lookup = target.lookup.copy()
    raw = scheme(scheme_name).from_wildscan
    lookup[: max(raw) + 1] = min(target.ignored, default=0)
    for wildscan_id, scheme_id in raw.items():
        lookup[wildscan_id] = target.lookup[scheme_id]
    return lookup


@dataclass
class TransferResult:
    classes: list[tuple[int, str]]  # the shared classes scored
    train_points: dict[int, int]  # WildScan training points per class
    ceiling_points: dict[int, int]  # real training points per class
    test_points: dict[int, int]
    iou: dict[int, float]  # WildScan-trained
    ceiling_iou: dict[int, float]  # real-trained
    layout: str
    scans: dict[str, int]
    seconds: float

    def miou(self, which: dict[int, float]) -> float:
        scored = [which[c] for c, _ in self.classes if self.test_points.get(c, 0)]
        return float(np.mean(scored)) if scored else float("nan")


def _features(xyz, rotation, remission, pick, with_intensity):
    return scan_features(xyz, rotation, remission if with_intensity else None, pick)


def wildscan_training(train_dir: Path, scheme_name: str, target: Target, with_intensity: bool):
    """Features and target learning ids of every scan of the WildScan dataset."""
    ds = open_dataset(train_dir)
    import json

    dataset_scheme = json.loads((Path(train_dir) / "dataset.json").read_text())["spec"]["label_scheme"]
    lookup = wildscan_to_target(dataset_scheme, scheme_name, target)
    per_class = train_per_class(len(ds.rows), len(set(target.names) - target.ignored))
    features, labels = [], []
    for row in ds.rows:
        xyz, remission, _ = read_scan(ds, row)
        raw = _raw_labels(ds, row)
        label = lookup[raw]
        rng = stage_rng(int(row["seed"]), f"bench.learn.transfer.{row['scan']}")
        pick = train_sample(label, target.ignored, rng, per_class)
        features.append(_features(xyz, scan_rotation(row), remission, pick, with_intensity))
        labels.append(label[pick])
    return _stack(features, labels), len(ds.rows)


def _raw_labels(ds, row) -> np.ndarray:
    return np.fromfile(ds.root / velodyne_files(row)[1], dtype="<u4").astype(np.int64) & 0xFFFF


def _stack(features, labels):
    if not features:
        return np.zeros((0, 1), dtype=np.float32), np.zeros(0, dtype=np.int64)
    return np.concatenate(features), np.concatenate(labels)


def real_splits(pairs, layout: RealLayout, target: Target, with_intensity: bool):
    """((features, labels) of the ceiling's training points, of the scored test points)."""
    if with_intensity and layout.columns == 3:
        raise UserError(f"--with-intensity: {layout.name} scans carry no remission", setting="with_intensity")
    cut = len(pairs) // 2  # the earlier half trains the ceiling, the later half is scored
    per_class = train_per_class(max(1, cut), len(set(target.names) - target.ignored))
    parts = {"ceiling": ([], []), "test": ([], [])}
    for k, (cloud, label_file) in enumerate(pairs):
        xyz, remission, raw = read_real_scan(layout, cloud, label_file)
        label = target.lookup[raw]
        rng = stage_rng(0, f"bench.learn.real.{k}")
        which = "ceiling" if k < cut else "test"
        if which == "ceiling":
            pick = train_sample(label, target.ignored, rng, per_class)
        else:
            pick = test_sample(label, target.ignored, rng)
        parts[which][0].append(_features(xyz, np.eye(3), remission, pick, with_intensity))
        parts[which][1].append(label[pick])
    return _stack(*parts["ceiling"]), _stack(*parts["test"]), cut


def iou_over(classes: list[int], truth: np.ndarray, predicted: np.ndarray) -> dict[int, float]:
    """IoU of each of `classes` on the points whose truth is one of them (a prediction of a
    class outside them is a miss of the truth's class)."""
    out = {}
    for c in classes:
        t, p = truth == c, predicted == c
        union = int((t | p).sum())
        out[c] = float((t & p).sum() / union) if union else 0.0
    return out


def bench_transfer(train_dir: Path, real_dir: Path, scheme_name: str, with_intensity: bool = False):
    t0 = time.perf_counter()
    target = target_of(scheme_name)
    layout, pairs = find_real_scans(real_dir)
    if len(pairs) < 2:
        raise UserError(
            f"{real_dir} has {len(pairs)} labelled scan: the suite needs at least 2 (half train the "
            "ceiling, half are scored)",
            setting="test",
        )
    (x_train, y_train), train_scans = wildscan_training(train_dir, scheme_name, target, with_intensity)
    (x_ceiling, y_ceiling), (x_test, y_test), cut = real_splits(pairs, layout, target, with_intensity)
    shared = sorted(set(np.unique(y_train).tolist()) & set(np.unique(y_test).tolist()) - target.ignored)
    if not shared:
        raise UserError(
            f"the WildScan dataset and {real_dir} share no class in {scheme_name}'s learning ids",
            setting="test",
        )
    scored = np.isin(y_test, shared)
    x_test, y_test = x_test[scored], y_test[scored]
    iou = iou_over(shared, y_test, fit_predict(x_train, y_train, x_test)[0])
    ceiling = iou_over(shared, y_test, fit_predict(x_ceiling, y_ceiling, x_test)[0])
    return TransferResult(
        classes=[(c, target.names.get(c, str(c))) for c in shared],
        train_points={c: int((y_train == c).sum()) for c in shared},
        ceiling_points={c: int((y_ceiling == c).sum()) for c in shared},
        test_points={c: int((y_test == c).sum()) for c in shared},
        iou=iou,
        ceiling_iou=ceiling,
        layout=layout.name,
        scans={"wildscan": train_scans, "ceiling": cut, "test": len(pairs) - cut},
        seconds=time.perf_counter() - t0,
    )


def transfer_table(result: TransferResult) -> list[str]:
    lines = [
        "| class | WildScan train points | real train points | real test points | IoU WildScan -> real "
        "| IoU real -> real (ceiling) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for c, name in result.classes:
        lines.append(
            f"| {name} | {result.train_points[c]:,} | {result.ceiling_points[c]:,} | "
            f"{result.test_points[c]:,} | {100 * result.iou[c]:.1f} % | {100 * result.ceiling_iou[c]:.1f} % |"
        )
    lines += [
        "",
        f"mIoU over the {len(result.classes)} shared classes: WildScan -> real "
        f"{100 * result.miou(result.iou):.1f} %, real -> real {100 * result.miou(result.ceiling_iou):.1f} % "
        "(ceiling).",
    ]
    return lines


def print_transfer(train_dir: Path, real_dir: Path, scheme_name: str, result: TransferResult) -> None:
    s = result.scans
    print(
        f"learn suite, transfer: trained on {train_dir} ({s['wildscan']} WildScan scans), scored on "
        f"{real_dir} ({result.layout} layout, {scheme_name} ids: the later {s['test']} of its scans; the "
        f"earlier {s['ceiling']} train the ceiling)"
    )
    print()
    print("\n".join(transfer_table(result)))
    print()
    print(f"time: {result.seconds:.1f} s")


def run_transfer(args) -> int:
    """The CLI's entry for --test REAL_DIR --scheme NAME: WildScan-trained against real-trained."""
    if args.dataset is None:
        raise UserError("--suite learn needs the dataset folder: wildscan bench --suite learn DIR")
    if args.test is None or args.scheme is None:
        missing = "--test REAL_DIR" if args.test is None else "--scheme NAME"
        raise UserError(
            f"--suite learn scores real scans with --test REAL_DIR and --scheme NAME: add {missing}"
        )
    if args.card:
        raise UserError("--card applies to --suite learn DIR alone (its own split), not with --test")
    train, real = Path(args.dataset), Path(args.test)
    result = bench_transfer(train, real, args.scheme, args.with_intensity)
    print_transfer(train, real, args.scheme, result)
    return 0
