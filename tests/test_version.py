"""The version is written once, in bl_info (addon/wildscan/__init__.py); everything else
derives from it and this test fails the moment anything disagrees."""

from __future__ import annotations

import ast
import re
import sys

import pytest
import tomllib

import wildscan

from tests.helpers.scene_helpers import REPO

sys.path.insert(0, str(REPO / "tools"))
try:
    import build_addon
finally:
    sys.path.pop(0)

VERSION = ".".join(str(v) for v in wildscan.bl_info["version"])


def test_bl_info_is_a_literal_blenders_legacy_loader_can_read():
    tree = ast.parse((REPO / "addon" / "wildscan" / "__init__.py").read_text())
    (node,) = [n for n in tree.body if isinstance(n, ast.Assign) and n.targets[0].id == "bl_info"]
    assert ast.literal_eval(node.value)["version"] == wildscan.bl_info["version"]


def test_every_place_that_names_the_version_agrees_with_bl_info():
    assert wildscan.__version__ == VERSION
    assert build_addon.package_version() == VERSION

    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "version" not in pyproject["project"] and "version" in pyproject["project"]["dynamic"]
    assert pyproject["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "wildscan.__version__"}

    manifest = tomllib.loads((REPO / "addon" / "wildscan" / "blender_manifest.toml").read_text())
    assert "version" not in manifest  # written into the zip by build_addon
    zipped = build_addon.extension_manifest(build_addon.check_manifest(build_addon.PACKAGE), VERSION, [])
    assert tomllib.loads(zipped)["version"] == VERSION

    # the README's install instructions name the zips build_addon writes
    named = set(
        re.findall(r"wildscan-(\d[\w.]*)-(?:extension|legacy)\.zip", (REPO / "README.md").read_text())
    )
    assert named == {VERSION}


@pytest.mark.filterwarnings("ignore:Support for `\\[tool.setuptools\\]`")
def test_setuptools_reads_the_version_from_the_package():
    read_configuration = pytest.importorskip("setuptools.config.pyprojecttoml").read_configuration
    assert read_configuration(REPO / "pyproject.toml")["project"]["version"] == VERSION


def test_no_other_file_spells_the_version_out():
    """A literal "X.Y.Z" of the current version anywhere else in the sources is a second
    place to forget (README install lines are checked above)."""
    literal = re.compile(rf"""["']{re.escape(VERSION)}["']""")
    found = []
    for path in [*(REPO / "addon").rglob("*.py"), *(REPO / "tools").rglob("*.py"), REPO / "pyproject.toml"]:
        if "egg-info" not in str(path) and literal.search(path.read_text(encoding="utf-8")):
            found.append(str(path.relative_to(REPO)))
    assert found == []
