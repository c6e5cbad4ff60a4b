"""The add-on in a real Blender GUI: Debian's Blender 3.4.1 under Xvfb.

tests/gui/run_gui.py does the clicking inside Blender (install the legacy zip, enable,
generate, aerial view, pose, scan, sidebar tab, screenshot, undo/redo, disable/enable)
and writes what it saw to a JSON file; this test asserts on it. The screenshot is kept
in the test's directory and copied to docs/screenshot.png for the README.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from tests.helpers.scene_helpers import BLENDER, REPO

# Debian's Blender 3.4 in a real window, under Xvfb
pytestmark = [pytest.mark.gui, pytest.mark.blender_binary, pytest.mark.slow]

GUI_SCRIPT = REPO / "tests" / "gui" / "run_gui.py"
SCREEN = "1600x1200x24"
RH = 2.0
TIMEOUT_S = 300
DOCS_SCREENSHOT = REPO / "docs" / "screenshot.png"


@pytest.fixture(scope="module")
def gui_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gui")
    sys.path.insert(0, str(REPO / "tools"))
    try:
        import build_addon
    finally:
        sys.path.pop(0)
    legacy, _extension = build_addon.build(tmp / "dist")
    for sub in ("scripts", "config", "tmp"):
        (tmp / sub).mkdir()
    # Blender installs and enables the add-on in a throw-away user directory, never the user's own.
    env = dict(
        os.environ,
        BLENDER_USER_SCRIPTS=str(tmp / "scripts"),
        BLENDER_USER_CONFIG=str(tmp / "config"),
        TMPDIR=str(tmp / "tmp"),
    )
    env.pop("PYTHONPATH", None)
    result_path, shot = tmp / "result.json", tmp / "screenshot.png"
    width, height = SCREEN.split("x")[:2]
    cmd = [
        "xvfb-run",
        "-a",
        "-s",
        f"-screen 0 {SCREEN}",
        BLENDER,
        "--factory-startup",
        "--enable-event-simulate",
        "-p",
        "0",
        "0",
        width,
        height,
        "--python",
        str(GUI_SCRIPT),
        "--",
        "--zip",
        str(legacy),
        "--result",
        str(result_path),
        "--screenshot",
        str(shot),
        "--rh",
        str(RH),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=TIMEOUT_S, cwd=tmp)
    (tmp / "blender.log").write_text(run.stdout + "\n--- stderr ---\n" + run.stderr)
    assert result_path.exists(), (
        f"Blender wrote no result (exit {run.returncode}):\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    )
    result = json.loads(result_path.read_text())
    if shot.exists():
        DOCS_SCREENSHOT.parent.mkdir(exist_ok=True)
        shutil.copyfile(shot, DOCS_SCREENSHOT)
    return {"result": result, "log": run.stdout + run.stderr, "shot": shot, "returncode": run.returncode}


def test_blender_ran_every_step_without_errors(gui_run):
    r = gui_run["result"]
    assert r["errors"] == [] and r.get("done") is True, r["errors"]
    assert r["blender_version"].startswith("3.4")
    assert "Traceback" not in gui_run["log"], gui_run["log"][-3000:]


def test_the_legacy_zip_is_installed_and_enabled(gui_run, tmp_path_factory):
    r = gui_run["result"]
    assert r["addon_enabled"] is True
    assert "/scripts/addons/wildscan/__init__.py" in r["addon_file"]  # the installed copy, not the repo


def test_each_operator_finished(gui_run):
    steps = gui_run["result"]["steps"]
    for name in ("generate_world", "aerial_view", "scan", "screenshot"):
        assert steps.get(name) == ["FINISHED"], (name, steps)


def test_the_aerial_view_looks_straight_down_with_a_large_cross(gui_run):
    r = gui_run["result"]
    assert r["world_objects"] > 5
    assert r["view_perspective"] == "ORTHO"
    assert [round(v, 6) for v in r["view_rotation"]] == [1, 0, 0, 0]
    assert r["marker"]["display"] == "PLAIN_AXES" and r["marker"]["size"] >= 0.5
    assert r["marker_follows_pose"] is True
    assert any(ok for _x, _y, ok, _text in r["pose_checks"])


def test_the_cloud_has_the_expected_points_and_classes(gui_run):
    r = gui_run["result"]
    cloud = r["cloud"]
    assert r["new_objects"] == [cloud["name"]]  # the scan added one object and nothing else
    assert cloud["points"] == cloud["cloud_points"] == sum(cloud["counts"].values())
    assert 1000 < cloud["points"] <= r["expected_beams"] == 1080 * int(180 / RH)
    assert 1 in cloud["classes"] and len(cloud["classes"]) >= 3  # terrain and more
    assert cloud["frame"] == "leveled"


def test_the_screenshot_shows_the_panel_and_the_cloud(gui_run):
    r = gui_run["result"]
    assert r["sidebar_shown"] is True and r["wildscan_tab_drawn"] is True
    stats = r["screenshot_stats"]
    assert stats["size"] == [int(v) for v in SCREEN.split("x")[:2]]
    assert stats["std"] > 10 and stats["distinct_colours"] > 200  # not blank
    # the points are drawn unlit in their class colours: terrain brown is all over the viewport
    assert stats["viewport_class_colour_pixels"]["1"] > 2000
    assert gui_run["shot"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert DOCS_SCREENSHOT.exists()


def test_undo_after_a_scan_removes_only_the_cloud_and_redo_brings_it_back(gui_run):
    r = gui_run["result"]
    assert r["after_undo"]["cloud_present"] is False
    assert r["after_undo"]["world_objects"] == r["after_undo"]["world_objects_before"]
    assert r["after_redo"]["clouds"] == [r["cloud"]["name"]]
    assert r["after_redo"]["points"] == r["cloud"]["points"]
    assert r["after_redo"]["world_objects"] == r["world_objects"]


def test_show_world_is_display_only(gui_run):
    r = gui_run["result"]["show_world"]
    assert r["hides_meshes"] and r["shown_again"] and r["same_scan"]
    assert r["hits"] > 45


def test_disable_and_enable_again_in_the_gui(gui_run):
    assert gui_run["result"]["disable_enable"] == {
        "unregistered": True,
        "registered_again": True,
        "settings_kept": True,
    }
