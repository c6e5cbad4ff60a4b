"""`wildscan bench --suite learn DIR`: what a fixed, CPU-only baseline learns from a dataset —
the ruler for every change to the worlds (docs/benchmarks.md "Learnability").

The baseline (fixed, so two datasets are compared by their data alone):

- the dataset's SemanticKITTI scans (`.bin` + `.label`, the pose of each from the manifest),
  labels through the label scheme's learning map, ignored classes left out;
- per point the geometric features of bench/learn_features.py (never intensity unless
  --with-intensity);
- training points: from every train scan, at most k points of each class, k = TRAIN_BUDGET /
  (train scans × learning classes), at least MIN_PER_CLASS (class-aware sampling: a rare
  class keeps all its points of a scan, the terrain is capped), drawn with a generator
  seeded from (world seed, split, scan);
- test points: TEST_PER_SCAN points of every scan of the test split (the val split when the
  test split has no world), uniformly, so the figures weigh the classes as the data does;
- scikit-learn's HistGradientBoostingClassifier with the MODEL settings below, fixed seed,
  no early stopping (no random validation split).

Printed: per class its training and test points and IoU = TP / (TP + FP + FN) on the test
points, the mIoU over the classes with test points, the confusion matrix (rows the truth,
columns the prediction, % of the row) and the time of each stage.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..core.rng import stage_rng
from .learn_features import feature_names, scan_features

TRAIN_BUDGET = 120_000  # training points at most, about (see train_per_class)
MIN_PER_CLASS = 40  # points of each class per train scan at least (when it has them)
TEST_PER_SCAN = 4000  # points per test scan, uniform
MODEL = dict(
    max_iter=150,
    learning_rate=0.1,
    max_leaf_nodes=63,
    min_samples_leaf=20,
    l2_regularization=1.0,
    early_stopping=False,
    random_state=0,
)
CARD_SUITE = "learn"  # its section of CARD.md (bench/markdown.py markers)


@dataclass
class Split:
    name: str
    features: list[np.ndarray] = field(default_factory=list)
    labels: list[np.ndarray] = field(default_factory=list)
    scans: int = 0

    def arrays(self, width: int) -> tuple[np.ndarray, np.ndarray]:
        if not self.features:
            return np.zeros((0, width), dtype=np.float32), np.zeros(0, dtype=np.int64)
        return np.concatenate(self.features), np.concatenate(self.labels)


@dataclass
class LearnResult:
    classes: list[tuple[int, str]]  # (learning id, name) of the classes scored
    train_points: dict[int, int]
    test_points: dict[int, int]
    iou: dict[int, float]
    confusion: np.ndarray  # (C, C) counts, rows truth, columns prediction (order of `classes`)
    test_split: str
    with_intensity: bool
    seconds: dict[str, float]
    scans: dict[str, int]

    @property
    def miou(self) -> float:
        scored = [self.iou[c] for c, _ in self.classes if self.test_points.get(c, 0) > 0]
        return float(np.mean(scored)) if scored else float("nan")


# ---------------------------------------------------------------------------------------
# the dataset


@dataclass(frozen=True)
class LearnDataset:
    root: Path
    learning_map: dict[int, int]  # raw label id -> learning id
    ignored: frozenset[int]
    names: dict[int, str]  # learning id -> name
    rows: tuple[dict, ...]  # the manifest's ok rows

    @property
    def classes(self) -> int:
        """Learning classes that are not ignored."""
        return len(set(self.learning_map.values()) - self.ignored)

    def lookup(self) -> np.ndarray:
        table = np.zeros(max(self.learning_map) + 1, dtype=np.int64)
        for raw, xid in self.learning_map.items():
            table[raw] = xid
        return table


def open_dataset(root: Path) -> LearnDataset:
    """The dataset at `root` as the suite reads it, or a UserError saying what is missing."""
    from ..app.dataset.card import read_dataset_json
    from ..app.dataset.manifest import Manifest
    from ..core.label_schemes import scheme

    root = Path(root)
    data = read_dataset_json(root) if root.is_dir() else None
    if data is None:
        raise UserError(
            f"{root} is not a WildScan dataset (no dataset.json): make one with `wildscan dataset`"
        )
    spec = data["spec"]
    _check_finished(root, data)
    if "semantickitti" not in spec["formats"]:
        raise UserError(
            f"{root}: the learn suite reads SemanticKITTI scans, and this dataset's formats are "
            f'{", ".join(spec["formats"])}: add "semantickitti" to formats'
        )
    s = scheme(spec["label_scheme"])
    tables = s.config_tables(bool(spec.get("weather")))
    ignored = frozenset(x for x, ign in tables["learning_ignore"].items() if ign)
    names = {xid: s.labels[raw] for xid, raw in tables["learning_map_inv"].items()}
    rows = tuple(r for r in Manifest.load(root).ok_rows())
    return LearnDataset(root, dict(tables["learning_map"]), ignored, names, rows)


def _check_finished(root: Path, data: dict) -> None:
    """A dataset being written, or stopped part-way (`--limit`, Ctrl-C), is refused: its
    splits would be measured on whatever scans happen to be there."""
    from ..app.dataset.lock import refuse_while_written

    refuse_while_written(root, "measure")
    if not data.get("complete"):
        totals = data.get("totals", {})
        done = totals.get("scans_ok", 0) + totals.get("scans_failed", 0)
        have = f" ({done:,} of {totals['scans_planned']:,} scans)" if "scans_planned" in totals else ""
        raise UserError(
            f"{root}: the dataset is incomplete{have}: finish it first (the same `wildscan dataset` "
            "command continues it), then measure it"
        )


def _velodyne(row: dict) -> tuple[str, str]:
    bins = [f["path"] for f in row["files"] if f["path"].split("/")[-2] == "velodyne"]
    path = bins[0]
    return path, path.replace("/velodyne/", "/labels/").removesuffix(".bin") + ".label"


def read_scan(ds: LearnDataset, row: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xyz, remission, learning id) of one scan, from its .bin and .label."""
    bin_path, label_path = _velodyne(row)
    points = np.fromfile(ds.root / bin_path, dtype="<f4").reshape(-1, 4)
    raw = np.fromfile(ds.root / label_path, dtype="<u4") & 0xFFFF
    return points[:, :3], points[:, 3], ds.lookup()[raw]


def scan_rotation(row: dict) -> np.ndarray:
    return np.array(row["pose_matrix"], dtype=np.float64).reshape(3, 4)[:, :3]


# ---------------------------------------------------------------------------------------
# sampling


def train_per_class(train_scans: int, classes: int) -> int:
    """Points of each class a train scan gives at most: TRAIN_BUDGET shared by the scans and
    classes, at least MIN_PER_CLASS (the training time grows with the points)."""
    return max(MIN_PER_CLASS, TRAIN_BUDGET // max(1, train_scans * classes))


def train_sample(label: np.ndarray, ignored: frozenset[int], rng, per_class: int) -> np.ndarray:
    """Indices of at most `per_class` points of each (not ignored) class, sorted."""
    picks = []
    for cid in np.unique(label):
        if int(cid) in ignored:
            continue
        where = np.flatnonzero(label == cid)
        if len(where) > per_class:
            where = rng.choice(where, per_class, replace=False)
        picks.append(where)
    return np.sort(np.concatenate(picks)) if picks else np.zeros(0, dtype=np.int64)


def test_sample(label: np.ndarray, ignored: frozenset[int], rng) -> np.ndarray:
    """Indices of TEST_PER_SCAN uniform points (all when fewer) that are not ignored, sorted."""
    where = np.flatnonzero(~np.isin(label, list(ignored)))
    if len(where) > TEST_PER_SCAN:
        where = rng.choice(where, TEST_PER_SCAN, replace=False)
    return np.sort(where)


def test_split_name(rows) -> str | None:
    """The split scored: test, or val when test has no scan; None when neither has one."""
    have = {r["split"] for r in rows}
    for name in ("test", "val"):
        if name in have:
            return name
    return None


def collect(ds: LearnDataset, with_intensity: bool, say=print) -> tuple[Split, Split]:
    """Features and labels of the sampled points of the train and the scored split."""
    scored = test_split_name(ds.rows)
    if scored is None or not any(r["split"] == "train" for r in ds.rows):
        splits = ", ".join(sorted({r["split"] for r in ds.rows})) or "none"
        raise UserError(
            f"{ds.root}: the learn suite trains on the train split and scores the test (or val) split, "
            f"and this dataset has scans in {splits} only: give more seeds (the default split 0.8/0.1/0.1 "
            "needs at least 10 worlds for a test world) or set split shares that give each a world"
        )
    train, test = Split("train"), Split(scored)
    per_class = train_per_class(sum(r["split"] == "train" for r in ds.rows), ds.classes)
    for row in ds.rows:
        target = {"train": train, scored: test}.get(row["split"])
        if target is None:
            continue
        xyz, remission, label = read_scan(ds, row)
        rng = stage_rng(int(row["seed"]), f"bench.learn.{row['split']}.{row['scan']}")
        if target is train:
            pick = train_sample(label, ds.ignored, rng, per_class)
        else:
            pick = test_sample(label, ds.ignored, rng)
        feats = scan_features(xyz, scan_rotation(row), remission if with_intensity else None, pick)
        target.features.append(feats)
        target.labels.append(label[pick])
        target.scans += 1
    return train, test


# ---------------------------------------------------------------------------------------
# the baseline


def bench_learn(root: Path, with_intensity: bool = False) -> LearnResult:
    try:
        from sklearn.ensemble import HistGradientBoostingClassifier
    except ImportError:
        raise UserError(
            "the learn suite needs scikit-learn: pip install scikit-learn (the `learn` extra)"
        ) from None
    ds = open_dataset(root)
    width = len(feature_names(with_intensity))
    t0 = time.perf_counter()
    train, test = collect(ds, with_intensity)
    x_train, y_train = train.arrays(width)
    x_test, y_test = test.arrays(width)
    t1 = time.perf_counter()
    from threadpoolctl import threadpool_limits

    # One thread: OpenMP's threads spin-wait, and on a shared, loaded machine two of them took
    # 13x as long as one (20k points, 12 classes: 42 s against 3.3 s); one is also the same
    # arithmetic everywhere.
    with threadpool_limits(1):
        model = HistGradientBoostingClassifier(**MODEL)
        model.fit(x_train, y_train)
        t2 = time.perf_counter()
        predicted = model.predict(x_test) if len(x_test) else np.zeros(0, dtype=np.int64)
    t3 = time.perf_counter()
    result = score(ds, y_train, y_test, predicted, test.name, with_intensity)
    result.seconds = {"features": t1 - t0, "training": t2 - t1, "prediction": t3 - t2}
    result.scans = {"train": train.scans, test.name: test.scans}
    return result


def score(ds: LearnDataset, y_train, y_test, predicted, split: str, with_intensity: bool) -> LearnResult:
    ids = sorted({int(c) for c in np.concatenate([y_train, y_test]).tolist()} - set(ds.ignored))
    index = {c: k for k, c in enumerate(ids)}
    confusion = np.zeros((len(ids), len(ids)), dtype=np.int64)
    for t, p in zip(y_test.tolist(), np.asarray(predicted).tolist(), strict=True):
        confusion[index[int(t)], index[int(p)]] += 1
    tp = np.diag(confusion).astype(np.float64)
    union = confusion.sum(axis=0) + confusion.sum(axis=1) - tp
    iou = {c: float(tp[k] / union[k]) if union[k] else 0.0 for c, k in index.items()}
    return LearnResult(
        classes=[(c, ds.names.get(c, str(c))) for c in ids],
        train_points={c: int((y_train == c).sum()) for c in ids},
        test_points={c: int((y_test == c).sum()) for c in ids},
        iou=iou,
        confusion=confusion,
        test_split=split,
        with_intensity=with_intensity,
        seconds={},
        scans={},
    )


# ---------------------------------------------------------------------------------------
# the report


def result_table(result: LearnResult) -> list[str]:
    """The per-class table and the mIoU line (markdown; the card takes them as they are)."""
    lines = ["| class | train points | test points | IoU |", "|---|---:|---:|---:|"]
    for cid, name in result.classes:
        n = result.test_points[cid]
        iou = f"{100 * result.iou[cid]:.1f} %" if n else "(none in test)"
        lines.append(f"| {name} | {result.train_points[cid]:,} | {n:,} | {iou} |")
    features = "geometry and remission" if result.with_intensity else "geometry only, no intensity"
    lines += ["", f"mIoU {100 * result.miou:.1f} % on the {result.test_split} split ({features})."]
    return lines


def confusion_lines(result: LearnResult) -> list[str]:
    short = [name[:8] for _, name in result.classes]
    lines = ["Confusion (rows: truth, columns: prediction, % of the row):", ""]
    lines.append(f"{'':>12} " + " ".join(f"{s:>8}" for s in short))
    for k, (_, name) in enumerate(result.classes):
        row = result.confusion[k]
        total = max(1, int(row.sum()))
        lines.append(f"{name[:12]:>12} " + " ".join(f"{100 * v / total:8.1f}" for v in row))
    return lines


def print_result(root: Path, result: LearnResult) -> None:
    s = result.seconds
    print(f"learn suite on {root}: {result.scans.get('train', 0)} train scans, "
          f"{result.scans.get(result.test_split, 0)} {result.test_split} scans; "
          f"{len(feature_names(result.with_intensity))} features per point")  # fmt: skip
    print()
    print("\n".join(result_table(result)))
    print()
    print("\n".join(confusion_lines(result)))
    print()
    print(
        f"time: features {s['features']:.1f} s, training {s['training']:.1f} s, "
        f"prediction {s['prediction']:.1f} s (total {sum(s.values()):.1f} s)"
    )


def write_card_section(root: Path, result: LearnResult, command: str) -> Path:
    """The table into the dataset's CARD.md, in a section of its own, replaced when run again
    (a later `wildscan dataset` run into DIR writes the card anew, without it)."""
    from ..core.io.files import atomic_outputs
    from .markdown import begin_marker, end_marker, replace_section, run_facts

    card = Path(root) / "CARD.md"
    if not card.exists():
        raise UserError(
            f"{card} does not exist: the dataset has no card yet (finish it with `wildscan dataset`)"
        )
    facts = run_facts(command)
    section = "\n".join(
        [
            begin_marker(CARD_SUITE),
            "## Learnability",
            "",
            f"`{facts.command}` on {facts.date}, {facts.machine}, WildScan {facts.version}: "
            "the fixed baseline of docs/benchmarks.md.",
            "",
            *result_table(result),
            end_marker(CARD_SUITE),
        ]
    )
    page = replace_section(card.read_text(encoding="utf-8"), CARD_SUITE, section)
    with atomic_outputs(card) as (tmp,):
        tmp.write_text(page, encoding="utf-8")
    return card


def result_json(result: LearnResult) -> str:
    return json.dumps(
        {
            "miou": result.miou,
            "iou": {name: result.iou[c] for c, name in result.classes},
            "test_split": result.test_split,
            "with_intensity": result.with_intensity,
        },
        indent=1,
    )


def run_learn(args) -> int:
    """The CLI's entry: measure, print, and with --card write the card's section."""
    if args.dataset is None:
        raise UserError("--suite learn needs the dataset folder: wildscan bench --suite learn DIR")
    root = Path(args.dataset)
    result = bench_learn(root, args.with_intensity)
    print_result(root, result)
    if args.card:
        card = write_card_section(root, result, getattr(args, "command_line", "wildscan bench --suite learn"))
        print(f"wrote the learn table into {card}")
    return 0
