"""Drive the WildScan add-on in a real Blender GUI (run by tests/test_gui.py under Xvfb).

    blender --factory-startup --enable-event-simulate --python tests/gui/run_gui.py -- \
        --zip dist/wildscan-X-legacy.zip --result result.json --screenshot shot.png

Installs the legacy zip the way a user would (Preferences > Add-ons > Install),
enables it, then from bpy.app.timers (so the window is up and redraws between steps):
generates a small world, opens the aerial view, places the pose, runs
wildscan.scan, opens the sidebar on the WildScan tab, takes a screenshot, checks
undo/redo and disable/enable, and writes everything it saw to the result JSON.
It never raises out of a step: failures go to the JSON, then Blender quits.
"""

import argparse
import json
import math
import sys
import time
import traceback

import addon_utils
import bpy
import numpy as np

ARGS = None
RESULT: dict = {"steps": {}, "errors": []}
STATE: dict = {"wildscan_drawn": 0, "tab_clicks": 0}
CLOSE_VIEW_DISTANCE_PER_M = 0.9  # view distance per metre of the scanned disc (lens 50: ~1.3 m per unit)
SCROLL_NOTCHES = 12  # wheel steps down the sidebar (it stops at its end)
STEP_DELAY = 0.4  # s between steps, so the window redraws


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    p = argparse.ArgumentParser()
    p.add_argument("--zip", required=True)
    p.add_argument("--result", required=True)
    p.add_argument("--screenshot", required=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--rh", type=float, default=4.0)
    return p.parse_args(argv)


def write_result():
    with open(ARGS.result, "w") as f:
        json.dump(RESULT, f, indent=2, default=str)


def finish():
    write_result()
    bpy.ops.wm.quit_blender()


# --------------------------------------------------------------------------- context


def window():
    return bpy.context.window_manager.windows[0]


def view3d():
    """(area, WINDOW region, UI region) of the largest 3D viewport."""
    areas = [a for a in window().screen.areas if a.type == "VIEW_3D"]
    area = max(areas, key=lambda a: a.width * a.height)
    regions = {r.type: r for r in area.regions}
    return area, regions["WINDOW"], regions.get("UI")


def override(**extra):
    area, region, _ui = view3d()
    return bpy.context.temp_override(
        window=window(), screen=window().screen, area=area, region=region, **extra
    )


def run_op(name, op, **kwargs):
    with override():
        result = op(**kwargs)
    RESULT["steps"][name] = sorted(result)
    return result


# --------------------------------------------------------------------------- steps


def step_enable():
    bpy.ops.preferences.addon_install(filepath=ARGS.zip, overwrite=True)
    addon_utils.enable("wildscan", default_set=True, handle_error=None)
    mod = sys.modules.get("wildscan")
    RESULT["addon_enabled"] = "wildscan" in bpy.context.preferences.addons
    RESULT["addon_file"] = getattr(mod, "__file__", None)
    RESULT["blender_version"] = bpy.app.version_string
    # Count draws of the World panel: it only draws while the sidebar shows the WildScan tab.
    panel = bpy.types.VIEW3D_PT_wildscan_world
    original = panel.draw

    def counting_draw(self, context):
        STATE["wildscan_drawn"] += 1
        return original(self, context)

    panel.draw = counting_draw
    # One big viewport: the screenshot then shows the world, the cloud and the sidebar.
    area, _region, _ui = view3d()
    with bpy.context.temp_override(window=window(), area=area):
        bpy.ops.screen.screen_full_area()
    return "generate"


def step_generate():
    s = bpy.context.scene.wildscan
    s.seed = ARGS.seed
    s.detail = "low"
    s.world_layout = "paper"  # the paper's island: the screenshots show its zones
    run_op("generate_world", bpy.ops.wildscan.generate_world)
    from wildscan.ui.scene import world_objects

    RESULT["world_objects"] = len(world_objects(bpy.context.scene))
    return "aerial"


def step_aerial():
    run_op("aerial_view", bpy.ops.wildscan.aerial_view)
    area, _region, _ui = view3d()
    r3d = area.spaces.active.region_3d
    RESULT["view_perspective"] = r3d.view_perspective
    RESULT["view_rotation"] = list(r3d.view_rotation)
    marker = bpy.context.scene.wildscan.marker
    RESULT["marker"] = (
        None
        if marker is None
        else {"name": marker.name, "display": marker.empty_display_type, "size": marker.empty_display_size}
    )
    return "pose"


def step_pose():
    """Place the pose where the live check says the robot can stand (the world may change
    with the generator, so search a small grid near the centre)."""
    from wildscan.ui import status

    s = bpy.context.scene.wildscan
    checked = []
    for x, y in [(0.0, 0.0), (2.0, 1.0), (-3.0, 2.0), (4.0, -4.0), (-5.0, -5.0), (6.0, 3.0), (1.0, 7.0)]:
        s.pose_x, s.pose_y, s.pose_yaw = x, y, 30.0
        state = status.pose_status(bpy.context.scene)
        checked.append((x, y, state.ok, state.text))
        if state.ok:
            break
    RESULT["pose_checks"] = checked
    RESULT["pose"] = [s.pose_x, s.pose_y, s.pose_yaw]
    marker = s.marker
    RESULT["marker_follows_pose"] = (
        marker is not None
        and math.isclose(marker.location[0], s.pose_x)
        and math.isclose(marker.location[1], s.pose_y)
    )
    return "scan"


def step_scan():
    from wildscan.ui.scene import cloud_counts, current_cloud, read_cloud

    s = bpy.context.scene.wildscan
    s.rh = ARGS.rh
    s.noise_seed = 3
    before = {o.name for o in bpy.data.objects}
    # Operators called from a timer push no undo step; pressing the button would. Push the
    # steps a user's click makes, so Ctrl+Z below undoes the scan as it would for a user.
    with override():
        bpy.ops.ed.undo_push(message="before WildScan scan")
    t0 = time.perf_counter()
    run_op("scan", bpy.ops.wildscan.scan)
    RESULT["scan_seconds"] = time.perf_counter() - t0
    with override():
        bpy.ops.ed.undo_push(message="Scan")
    obj = current_cloud(bpy.context)
    RESULT["new_objects"] = sorted({o.name for o in bpy.data.objects} - before)
    cloud = read_cloud(obj)
    RESULT["cloud"] = {
        "name": obj.name,
        "points": len(obj.data.vertices),
        "cloud_points": len(cloud),
        "classes": sorted(int(c) for c in np.unique(cloud.label)),
        "counts": {str(k): v for k, v in cloud_counts(obj).items()},
        "frame": cloud.frame,
    }
    RESULT["expected_beams"] = 1080 * round(180 / ARGS.rh)
    return "closer"


def step_closer():
    """Still looking straight down, come closer: the screenshot shows the scanned disc (twice
    the max range across) rather than the whole world."""
    area, _region, _ui = view3d()
    s = bpy.context.scene.wildscan
    r3d = area.spaces.active.region_3d
    r3d.view_location = (s.pose_x, s.pose_y, r3d.view_location[2])
    r3d.view_distance = min(r3d.view_distance, CLOSE_VIEW_DISTANCE_PER_M * 2 * s.max_range)
    return "sidebar"


def step_sidebar():
    area, _region, _ui = view3d()
    area.spaces.active.show_region_ui = True
    STATE["wildscan_drawn"] = 0
    return "tab"


def step_tab():
    """Bring the WildScan tab forward: set the region's active category where Blender allows
    it (4.1+); on older versions click down the tab strip on the sidebar's right edge, one
    click per step, until the WildScan panels draw."""
    area, _region, ui = view3d()
    if STATE["wildscan_drawn"] > 0:
        RESULT["tab_clicks"] = STATE["tab_clicks"]
        return "scroll"
    if STATE["tab_clicks"] > 60:
        RESULT["errors"].append("could not bring the WildScan tab forward")
        return "scroll"
    if "active_panel_category" in ui.bl_rna.properties.keys():
        ui.active_panel_category = "WildScan"
    else:
        x = ui.x + ui.width - 8
        y = ui.y + ui.height - 10 - 10 * STATE["tab_clicks"]
        click(x, y)
    STATE["tab_clicks"] += 1
    area.tag_redraw()
    return "tab"


def click(x, y):
    win = window()
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    win.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
    win.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)


def step_scroll():
    """Scroll the sidebar to its end so the Result panel's legend is in the screenshot, then park
    the mouse over the viewport (no tooltip in the picture)."""
    _area, _region, ui = view3d()
    win = window()
    x, y = ui.x + ui.width // 2, ui.y + ui.height // 2
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    for _ in range(SCROLL_NOTCHES):
        win.event_simulate(type="WHEELDOWNMOUSE", value="PRESS", x=x, y=y)
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=40, y=ui.y + 40)
    return "shot"


def step_shot():
    area, _region, ui = view3d()
    RESULT["sidebar_shown"] = area.spaces.active.show_region_ui
    RESULT["sidebar_width"] = ui.width if ui else 0
    RESULT["wildscan_tab_drawn"] = STATE["wildscan_drawn"] > 0
    with override():
        result = bpy.ops.screen.screenshot(filepath=ARGS.screenshot)
    RESULT["steps"]["screenshot"] = sorted(result)
    RESULT["screenshot_stats"] = image_stats(ARGS.screenshot, ui)
    return "undo"


COLOUR_TOLERANCE = 8  # the viewport dithers colours by a few levels


def image_stats(path, ui):
    """What the screenshot shows: overall variety, and in the viewport part (left of the
    sidebar, so the legend's swatches do not count) the pixels in each class colour."""
    from wildscan.core.classes import COLOR_BY_ID

    img = bpy.data.images.load(path)
    try:
        w, h = img.size
        px = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    rgb = np.round(px.reshape(h, w, 4)[:, :, :3] * 255).astype(np.int32)  # rows bottom-up, as window y
    flat = rgb.reshape(-1, 3)
    colours = np.unique(flat[:: max(1, len(flat) // 200_000)], axis=0)
    viewport = rgb[:, : ui.x].reshape(-1, 3) if ui is not None else flat
    near = {}
    for class_id in RESULT.get("cloud", {}).get("classes", []):
        d = np.abs(viewport - COLOR_BY_ID[class_id].astype(np.int32)).max(axis=1)
        near[str(class_id)] = int((d <= COLOUR_TOLERANCE).sum())
    return {
        "size": [w, h],
        "std": float(rgb.std()),
        "distinct_colours": int(len(colours)),
        "viewport_class_colour_pixels": near,
    }


def step_undo():
    from wildscan.ui.scene import clouds, read_cloud, world_objects

    scene = bpy.context.scene
    n_world = len(world_objects(scene))
    name = RESULT["cloud"]["name"]
    with override():
        bpy.ops.ed.undo()
    scene = bpy.context.scene
    RESULT["after_undo"] = {
        "cloud_present": bpy.data.objects.get(name) is not None,
        "world_objects": len(world_objects(scene)),
        "world_objects_before": n_world,
    }
    with override():
        bpy.ops.ed.redo()
    scene = bpy.context.scene
    found = clouds(scene)
    RESULT["after_redo"] = {
        "clouds": [o.name for o in found],
        "points": len(read_cloud(found[-1])) if found else 0,
        "world_objects": len(world_objects(scene)),
    }
    return "showworld"


def step_showworld():
    """'Show world' off hides the meshes in the viewports, and a scan sees the same world."""
    from wildscan.app.scan import make_scene_backend
    from wildscan.core.placement import Pose
    from wildscan.core.sensors import SensorConfig

    s = bpy.context.scene.wildscan
    pose, sensor = Pose(s.pose_x, s.pose_y, 0.0), SensorConfig()
    angles = np.linspace(0.0, 2.0 * np.pi, 90, endpoint=False)
    dirs = np.column_stack([np.cos(angles), np.sin(angles), np.full(90, -0.3)])
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    origin = np.array([s.pose_x, s.pose_y, 5.0])

    def ranges(backend):
        caster = make_scene_backend(backend, pose, sensor, notify=lambda _t: None)
        return caster.cast(origin, dirs, 30.0).distance

    before = {b: ranges(b) for b in ("auto", "blender")}
    s.show_world = False
    area, _region, _ui = view3d()
    hidden = not area.spaces.active.show_object_viewport_mesh and not s.show_world
    after = {b: ranges(b) for b in ("auto", "blender")}
    s.show_world = True
    RESULT["show_world"] = {
        "hides_meshes": hidden,
        "shown_again": area.spaces.active.show_object_viewport_mesh and s.show_world,
        "hits": int(np.isfinite(before["auto"]).sum()),
        "same_scan": all(np.array_equal(before[b], after[b]) for b in before),
    }
    return "toggle"


def step_toggle():
    addon_utils.disable("wildscan", default_set=True)
    gone = not hasattr(bpy.types.Scene, "wildscan")
    addon_utils.enable("wildscan", default_set=True, handle_error=None)
    RESULT["disable_enable"] = {
        "unregistered": gone,
        "registered_again": hasattr(bpy.types.Scene, "wildscan") and hasattr(bpy.ops.wildscan, "scan"),
        "settings_kept": abs(bpy.context.scene.wildscan.rh - ARGS.rh) < 1e-9,
    }
    return None


STEPS = {
    "enable": step_enable,
    "generate": step_generate,
    "aerial": step_aerial,
    "pose": step_pose,
    "scan": step_scan,
    "closer": step_closer,
    "sidebar": step_sidebar,
    "tab": step_tab,
    "scroll": step_scroll,
    "shot": step_shot,
    "undo": step_undo,
    "showworld": step_showworld,
    "toggle": step_toggle,
}


def runner(name):
    def tick():
        try:
            following = STEPS[name]()
        except Exception:
            RESULT["errors"].append(f"{name}: {traceback.format_exc()}")
            following = None
        write_result()
        if following is None:
            RESULT["done"] = True
            bpy.app.timers.register(finish, first_interval=STEP_DELAY)
        else:
            bpy.app.timers.register(runner(following), first_interval=STEP_DELAY)
        return None

    return tick


if __name__ == "__main__":
    ARGS = parse_args()
    bpy.context.preferences.view.show_splash = False  # the splash would cover the screenshot
    bpy.app.timers.register(runner("enable"), first_interval=1.0)
