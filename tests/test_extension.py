"""The fast ray caster inside Blender: the 4.2+ extension zip bundles the embreex wheels,
lists them in its manifest, and once installed Blender's Python scans with Embree.

The install is the real one of Blender 5.0 (the bpy 5.0.1 wheel's
`extensions.package_install_files`, what Install from Disk and `blender --command
extension install-file` run), into temporary user directories, in a Python where the
venv's own embreex cannot be imported: only the wheel Blender unpacked from the zip can
give the embree backend.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import zipfile

import pytest
import tomllib

import wildscan

from tests.helpers.scene_helpers import CANDIDATE_XY, REPO

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

sys.path.insert(0, str(REPO / "tools"))
try:
    import build_addon
finally:
    sys.path.pop(0)


@pytest.fixture(scope="module")
def zips(tmp_path_factory):
    return build_addon.build(tmp_path_factory.mktemp("dist"))


def test_the_extension_holds_a_wheel_per_platform_and_its_manifest_lists_them(zips):
    _legacy, extension = zips
    with zipfile.ZipFile(extension) as z:
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
        wheels = sorted(n for n in z.namelist() if n.startswith("wheels/"))
        assert all(z.getinfo(n).compress_type == zipfile.ZIP_STORED for n in wheels)
    assert manifest["version"] == wildscan.__version__
    assert sorted(manifest["wheels"]) == [f"./{n}" for n in wheels]
    assert "platforms" not in manifest  # pure Python: a platform without a wheel uses the BVH
    assert len(wheels) == len(build_addon.WHEEL_PLATFORMS) == 4
    tags = [n.removesuffix(".whl").split("-")[-1] for n in wheels]
    for name in wheels:
        assert name.startswith(f"wheels/embreex-{build_addon.EMBREEX_VERSION}-cp311-cp311-"), name
    for machine in ("_x86_64", "win_amd64", "macosx_13_0_x86_64", "macosx_13_0_arm64"):
        assert any(t.endswith(machine) for t in tags), (machine, tags)


def test_the_legacy_zip_bundles_no_wheels(zips):
    legacy, _extension = zips
    with zipfile.ZipFile(legacy) as z:
        assert not any(n.endswith(".whl") or n.endswith("blender_manifest.toml") for n in z.namelist())


def test_the_same_sources_give_the_same_zips(zips, tmp_path):
    again = build_addon.build(tmp_path)
    for first, second in zip(zips, again):
        assert first.read_bytes() == second.read_bytes(), first.name


INSTALL_SCRIPT = r"""
import importlib.abc, importlib.machinery, os, sys
zip_path, user_dir, repo_addon, venv_site = sys.argv[1:5]
# The package is also installed editable (repo/addon on sys.path): hide that copy so the
# one Blender installs from the zip runs.
sys.path[:] = [p for p in sys.path if p.rstrip("/") != repo_addon]


class HideTheVenvsEmbreex(importlib.abc.MetaPathFinder):
    # `import embreex` looks everywhere on sys.path except in the venv's site-packages
    def find_spec(self, name, path=None, target=None):
        if name != "embreex":
            return None
        elsewhere = [p for p in sys.path if os.path.realpath(p) != venv_site]
        spec = importlib.machinery.PathFinder.find_spec(name, elsewhere)
        if spec is None:
            raise ModuleNotFoundError("No module named 'embreex'", name=name)
        return spec


sys.meta_path.insert(0, HideTheVenvsEmbreex())
try:
    import embreex
    print("BEFORE embreex", embreex.__file__)
except ImportError:
    print("BEFORE no embreex")

import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
assert bpy.ops.extensions.package_install_files(
    filepath=zip_path, repo="user_default", enable_on_install=True
) == {"FINISHED"}
module = sys.modules["bl_ext.user_default.wildscan"]
assert module.__file__.startswith(user_dir), module.__file__
print("BACKEND", module.raycast.select.resolve_backend("auto"))
import embreex
print("EMBREEX", os.path.realpath(embreex.__file__))
s = bpy.context.scene.wildscan
s.seed, s.detail, s.world_layout = 3, "low", "paper"
assert bpy.ops.wildscan.generate_world() == {"FINISHED"}
Pose = module.core.placement.Pose
SensorConfig = module.core.sensors.SensorConfig
check = module.ui.status.check_pose
pose = next(Pose(x, y, 0.0) for x, y in CANDIDATES if check(Pose(x, y, 0.0), None).ok)
scan = importlib.import_module(module.__name__ + ".app.scan")
result = scan.scan_current_scene(pose, SensorConfig(rh_deg=6.0), notify=print)
print("SCANNED", result.metadata["backend"], len(result.cloud))
"""


def test_installed_in_blender_5_the_extension_scans_with_embree(zips, tmp_path):
    _legacy, extension = zips
    user = (tmp_path / "user").resolve()
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), BLENDER_USER_SCRIPTS=str(user / "scripts"))
    venv_site = os.path.realpath(sysconfig.get_paths()["purelib"])
    run = subprocess.run(
        [
            sys.executable,
            "-c",
            f"CANDIDATES = {CANDIDATE_XY!r}\n" + INSTALL_SCRIPT,
            str(extension),
            str(user),
            str(REPO / "addon"),
            venv_site,
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        cwd=tmp_path,
    )
    out = run.stdout
    assert run.returncode == 0, out[-2000:] + run.stderr[-3000:]
    lines = dict(line.split(" ", 1) for line in out.splitlines() if line.split(" ", 1)[0].isupper())
    assert lines["BEFORE"] == "no embreex"
    assert lines["BACKEND"] == "embree"
    site = user / "extensions" / ".local" / "lib" / "python3.11" / "site-packages"
    assert lines["EMBREEX"].startswith(str(site)), lines["EMBREEX"]
    backend, points = lines["SCANNED"].split()
    assert backend == "embree" and int(points) > 1000
    assert "not available" not in out  # no fallback notice
