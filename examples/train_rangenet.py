"""Train a small RangeNet-style network on a WildScan dataset's range images (CPU is fine).

    python examples/train_rangenet.py DIR [--epochs 5] [--remission] [--weights enet] [--markdown FILE.md]

A few-layer encoder-decoder in the spirit of RangeNet++ (Milioto et al., IROS 2019: a
range-image CNN, downsampling only along the width, skip connections), weighted cross-
entropy with the dataset's class weights (labels.yaml), ignoring class 0. After each
epoch it prints the loss and the IoU per class on the range-image pixels of the valid
split (the test split when valid has no sequence). Needs torch; see examples/README.md.
With --markdown FILE.md it writes what it printed, with the command, date, machine and torch
version, into its marked section of FILE.md (docs/training.md is made this way).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.utils.data import DataLoader

sys.path.insert(0, str(Path(__file__).resolve().parent))

from wildscan_torch.data import iou_table  # noqa: E402
from wildscan_torch.dataset import WildScanRangeImages  # noqa: E402


def block(cin: int, cout: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.LeakyReLU(0.1),
        nn.Conv2d(cout, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.LeakyReLU(0.1),
    )  # fmt: skip


class RangeNetLite(nn.Module):
    """Encoder (widths halved three times, heights kept) and decoder with skip connections."""

    def __init__(self, channels: int, classes: int, width: int = 32):
        super().__init__()
        w = [width, width * 2, width * 4, width * 4]
        self.enc = nn.ModuleList(
            [block(channels, w[0]), block(w[0], w[1]), block(w[1], w[2]), block(w[2], w[3])]
        )
        self.down = nn.MaxPool2d((1, 2))
        self.up = nn.Upsample(scale_factor=(1, 2), mode="nearest")
        self.dec = nn.ModuleList(
            [block(w[3] + w[2], w[2]), block(w[2] + w[1], w[1]), block(w[1] + w[0], w[0])]
        )
        self.head = nn.Conv2d(w[0], classes, 1)

    def forward(self, x):
        skips = []
        for k, enc in enumerate(self.enc):
            x = enc(x)
            if k < len(self.enc) - 1:
                skips.append(x)
                x = self.down(x)
        for dec in self.dec:
            x = dec(torch.cat([self.up(x), skips.pop()], dim=1))
        return self.head(x)


def evaluate(model, loader, classes: int, ignore) -> tuple[dict[int, float], np.ndarray]:
    confusion = np.zeros((classes, classes), dtype=np.int64)
    model.eval()
    with torch.no_grad():
        for image, labels in loader:
            predicted = model(image).argmax(dim=1)
            keep = labels > 0
            t, p = labels[keep].numpy(), predicted[keep].numpy()
            confusion += np.bincount(t * classes + p, minlength=classes * classes).reshape(classes, classes)
    return iou_table(confusion, ignore), confusion


BEGIN = "<!-- begin examples/train_rangenet.py (generated: rerun the command below, do not edit) -->"
END = "<!-- end examples/train_rangenet.py -->"


def write_markdown(path: Path, argv: list[str], printed: list[str]) -> None:
    """The run's section of `path`: replaced in place when there, else appended."""
    import os
    import platform
    from datetime import datetime, timezone

    cpu = next(
        (line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
         if line.startswith("model name")), platform.processor()
    ) if Path("/proc/cpuinfo").exists() else platform.processor()  # fmt: skip
    section = "\n".join(
        [
            BEGIN,
            f"- Command: `python examples/train_rangenet.py {' '.join(argv)}`",
            f"- Date: {datetime.now(timezone.utc):%Y-%m-%d %H:%M UTC}",
            f"- Machine: {os.cpu_count()} cores, {cpu}, load average {os.getloadavg()[0]:.2f} at the end, "
            f"torch {torch.__version__} on the CPU, {torch.get_num_threads()} threads",
            "",
            "```text",
            *printed,
            "```",
            END,
        ]
    )
    page = path.read_text(encoding="utf-8") if path.exists() else ""
    if BEGIN in page and END in page:
        page = page[: page.index(BEGIN)] + section + page[page.index(END) + len(END) :]
    else:
        page = page.rstrip("\n") + "\n\n" + section + "\n"
    path.write_text(page, encoding="utf-8")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dataset", type=Path)
    p.add_argument("--epochs", type=int, default=5)
    p.add_argument("--batch", type=int, default=4)
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--remission", action="store_true", help="feed the remission as a fifth channel")
    p.add_argument("--weights", choices=("enet", "inverse_frequency"), default="enet")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--width", type=int, default=16, help="channels of the first block (doubled twice)")
    p.add_argument("--threads", type=int, default=1, help="torch threads (1: steady on a shared machine)")
    p.add_argument(
        "--train-every", type=int, default=1, help="train on every K-th train scan (a quicker run)"
    )
    p.add_argument("--markdown", type=Path, help="write the printed figures into this page's section")
    argv = sys.argv[1:] if argv is None else argv
    args = p.parse_args(argv)
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    printed: list[str] = []

    def say(line: str) -> None:
        print(line, flush=True)
        printed.append(line)

    train = WildScanRangeImages(args.dataset, "train", args.remission, args.weights)
    train.files = train.files[:: args.train_every]
    scored = "valid" if train.config.split.get("valid") else "test"
    valid = WildScanRangeImages(args.dataset, scored, args.remission, args.weights)
    if not len(train) or not len(valid):
        print(
            f"{args.dataset}: needs scans in train and in valid or test (labels.yaml split)", file=sys.stderr
        )
        return 2
    classes = train.config.classes
    model = RangeNetLite(train[0][0].shape[0], classes, args.width)
    weights = train.class_weights.clone()
    weights[0] = 0.0
    loss_fn = nn.CrossEntropyLoss(weight=weights, ignore_index=0)
    optimiser = torch.optim.Adam(model.parameters(), lr=args.lr)
    loader = DataLoader(
        train, batch_size=args.batch, shuffle=True, generator=torch.Generator().manual_seed(0)
    )
    scoring = DataLoader(valid, batch_size=args.batch)
    say(f"{args.dataset.name}: {len(train)} train scans, {len(valid)} {scored} scans, {classes} classes, "
        f"{sum(q.numel() for q in model.parameters()):,} parameters")  # fmt: skip
    for epoch in range(1, args.epochs + 1):
        model.train()
        t0, total = time.perf_counter(), 0.0
        for image, labels in loader:
            optimiser.zero_grad()
            loss = loss_fn(model(image), labels)
            loss.backward()
            optimiser.step()
            total += float(loss.detach()) * len(image)
        iou, _ = evaluate(model, scoring, classes, train.config.ignore)
        miou = 100 * float(np.mean(list(iou.values()))) if iou else float("nan")
        say(f"epoch {epoch}: loss {total / len(train):.3f}, {scored} mIoU {miou:.1f} % "
            f"({time.perf_counter() - t0:.0f} s)")  # fmt: skip
    say(f"IoU per class on the {scored} pixels after epoch {args.epochs}:")
    for k, value in sorted(iou.items()):
        say(f"  {train.config.names[k]:<14} {100 * value:5.1f} %")
    if args.markdown:
        write_markdown(args.markdown, argv, printed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
