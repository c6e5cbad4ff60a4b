"""docs/extending.md's recipes, followed literally on a copy of the repository: every block
marked `<!-- recipe NAME: ... -->` is applied (a file created, lines added after the lines a
text names, a command run), then what each recipe promises is checked with the copy's own
`wildscan` (a new class, a per-beam dropout effect with its option and SPEC.toml key, a
sensor file with its generated table, a format read back by numpy)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tests.helpers.scene_helpers import REPO

pytestmark = pytest.mark.slow  # tens of seconds: a world's geometry and eight scans
PAPER_WORLD = ("--seed", "1", "--detail", "low", "--layout", "paper", "--biome", "paper")
CLI = "import sys\nfrom wildscan.cli import main\nsys.exit(main(sys.argv[1:]))"  # the copy's `wildscan`
MARK = re.compile(r"<!-- recipe (\w+): (.*?) -->\n(\s*)```\w*\n(.*?)\n\s*```", re.S)


def recipe_steps() -> list[tuple[str, str, str]]:
    """(recipe, action, code) of every marked block of docs/extending.md, in page order."""
    text = (REPO / "docs" / "extending.md").read_text(encoding="utf-8")
    return [(name, action, textwrap.dedent(code)) for name, action, _, code in MARK.findall(text)]


def apply(root: Path, action: str, code: str, env: dict) -> None:
    if action.startswith("create "):
        path = root / action.removeprefix("create ")
        assert not path.exists(), f"{path} exists: the recipe would overwrite it"
        path.write_text(code + "\n", encoding="utf-8")
    elif action.startswith("after "):
        found = re.fullmatch(r"after (['\"])(.*)\1 in (\S+)", action)
        assert found, action
        anchor, path = found.group(2), root / found.group(3)
        lines, out, hits = path.read_text(encoding="utf-8").split("\n"), [], 0
        for line in lines:
            out.append(line)
            if anchor in line:
                hits += 1
                indent = line[: len(line) - len(line.lstrip())]
                out += [indent + c if c else c for c in code.split("\n")]
        assert hits, f"no line of {path} holds {anchor!r}"
        path.write_text("\n".join(out), encoding="utf-8")
    elif action == "run":
        run = subprocess.run(code, shell=True, cwd=root, env=env, capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, f"{code}: {run.stdout} {run.stderr}"
    else:
        raise AssertionError(f"unknown recipe action {action!r}")


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    """The repository's files as a clone has them (git ls-files), every recipe applied."""
    root = tmp_path_factory.mktemp("clone")
    files = subprocess.run(
        ["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True, timeout=60
    )
    for name in files.stdout.splitlines():
        source = REPO / name
        if source.is_file():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, root / name)
    (root / ".venv").symlink_to(REPO / ".venv")
    env = dict(os.environ, PYTHONPATH=str(root / "addon"), XDG_CACHE_HOME=str(root / ".cache"))
    steps = recipe_steps()
    assert {name for name, _, _ in steps} == {"class", "effect", "sensor", "format"}
    for _, action, code in steps:
        apply(root, action, code, env)
    return root, env


def wildscan(clone, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    root, env = clone
    run = subprocess.run(
        [sys.executable, "-c", CLI, *args],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert not check or run.returncode == 0, run.stderr
    return run


def python(clone, code: str) -> str:
    root, env = clone
    run = subprocess.run(
        [sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True, timeout=600
    )
    assert run.returncode == 0, run.stderr
    return run.stdout


@pytest.fixture(scope="module")
def world(clone):
    """Seed 1's paper world (layout and biome) at low detail as a geometry file, and a valid
    forest pose."""
    out = clone[0] / "world.npz"
    wildscan(clone, "extract", *PAPER_WORLD, "--out", str(out), "--quiet")
    listed = wildscan(clone, "poses", *PAPER_WORLD, "--zone", "forest", "--count", "1", "--json")
    pose = json.loads(listed.stdout)["poses"]["forest"][0]
    return out, [str(pose["x"]), str(pose["y"]), str(pose["yaw"])]


def scan(clone, world, name: str, *options: str):
    from wildscan.core.io.ply import read_ply

    geometry, pose = world
    out = clone[0] / f"{name}.ply"
    wildscan(
        clone, "scan", "--geometry", str(geometry), "--pose", *pose, "--rh", "4", *options, "--out", str(out)
    )
    return read_ply(out)[0]


def beams(records) -> int:
    return len(np.unique(records["ring"].astype(np.int64) * 100_000 + records["sweep"]))


def test_a_new_class_is_a_line_its_schemes_and_docs_follow_and_old_files_keep_their_bytes(clone):
    facts = python(
        clone,
        "from wildscan.core.classes import class_by_name, listed_classes\n"
        "from wildscan.core.label_schemes import SCHEMES\n"
        "from wildscan.core.io.las import ASPRS_CODES\n"
        "c = class_by_name('Boulder')\n"
        "ids = lambda classes: [k.id for k in classes]\n"
        "print(c.id, c.optional, 30 in ids(listed_classes()), 30 in ids(listed_classes([30])))\n"
        "other = lambda s: s.other if s.other is not None else 30\n"
        "print(all(s.from_wildscan[30] == other(s) for s in SCHEMES.values()))\n"
        "print(ASPRS_CODES[30])\n",
    ).split()
    assert facts == ["30", "True", "False", "True", "True", "68"]
    assert "boulder" in (clone[0] / "docs" / "formats.md").read_text()  # the generated tables
    # a file without the class keeps its bytes: the same cloud written by the clone and by us
    code = (
        "import hashlib, numpy as np, tempfile, pathlib\n"
        "from wildscan.core.io.ply import write_scan_files\n"
        "from wildscan.core.pointcloud import PointCloud\n"
        "n = np.arange(12)\n"
        "c = PointCloud(np.c_[n, n, n].astype(float), n.astype(np.float32), (n + 1).astype(np.uint16),\n"
        "    n.astype(np.uint32), n.astype(np.uint16), n.astype(np.uint16), n.astype(np.float32))\n"
        "d = pathlib.Path(tempfile.mkdtemp())\n"
        "ply, side = write_scan_files(d / 's.ply', c, {'seed': 1})\n"
        "print(hashlib.sha256(ply.read_bytes() + side.read_bytes()).hexdigest())\n"
    )
    ours = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    ).stdout
    assert python(clone, code) == ours


def test_a_per_beam_dropout_is_one_module_and_one_line_with_its_option_and_spec_key(clone, world):
    assert "--dropout SHARE" in wildscan(clone, "scan", "--help").stdout
    refused = wildscan(
        clone, "scan", "--seed", "1", "--pose", "0", "0", "0", "--dropout", "2", "--out", "x.ply", check=False
    )
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1
    assert "--dropout must be a number from 0 to 1" in refused.stderr
    spec = python(
        clone,
        "from wildscan.app.dataset.spec import spec_from_dict\n"
        "from wildscan.app.dataset.draws import draw_effects\n"
        "from wildscan.core.errors import UserError\n"
        "spec = spec_from_dict({'effects': {'dropout': [0.2, 0.8]}})\n"
        "print(spec.effects, 0.2 <= draw_effects(spec, 0, 3)['dropout'] <= 0.8)\n"
        "try:\n"
        "    spec_from_dict({'effects': {'dropout': 2}})\n"
        "except UserError as e:\n"
        "    print(e)\n",
    )
    assert spec.splitlines() == [
        "(('dropout', (0.2, 0.8)),) True",
        "SPEC.toml: effects.dropout: must be a number from 0 to 1 of the beams, got 2",
    ]
    for model in ("paper", "realistic"):
        clear = scan(clone, world, f"clear-{model}", "--model", model)
        dropped = scan(clone, world, f"dropout-{model}", "--model", model, "--dropout", "0.5")
        removed = 1 - beams(dropped) / beams(clear)
        assert 0.4 <= removed <= 0.6, (model, removed)


def test_a_sensor_file_is_listed_documented_and_scans_with_its_own_limits(clone, world):
    assert "my-lidar" in wildscan(clone, "sensors").stdout
    assert "| my-lidar |" in (clone[0] / "docs" / "sensors.md").read_text()
    assert "my-lidar 50" in " ".join(wildscan(clone, "scan", "--help").stdout.split())
    records = scan(clone, world, "my-lidar", "--sensor", "my-lidar", "--rh", "0.4", "--max-range", "50")
    assert len(records) > 0 and set(np.unique(records["ring"])) <= set(range(8))


def test_a_format_is_one_module_and_one_line_and_numpy_reads_it_back(clone, world):
    geometry, pose = world
    out = clone[0] / "scan.xyz"
    wildscan(
        clone,
        "scan",
        "--geometry",
        str(geometry),
        "--pose",
        *pose,
        "--rh",
        "4",
        "--format",
        "xyz",
        "--out",
        str(out),
    )
    table = np.loadtxt(out)
    reference = scan(clone, world, "reference")
    assert table.shape == (len(reference), 4)
    np.testing.assert_array_equal(table[:, 3], reference["label"])
    np.testing.assert_allclose(table[:, :3], np.c_[reference["x"], reference["y"], reference["z"]], atol=1e-5)
