"""The add-on's settings, stored in the scene as `scene.wildscan` (saved with the .blend,
scriptable: set them, then call the operators).

The pose (x, y, yaw) is the pose marker's: while the marker exists the three
properties read and move it, so dragging the marker and typing numbers are the
same thing. Without a marker they are plain stored values.

Sensor limits are the chosen device's (`field_limits`, app/settings.py `limits`): the
fields' sliders span every preset's (`slider_limits`), and a value the device does not allow
(an r_h that does not divide its sweep, a range past its longest, a min range above the max)
is accepted here and named by the Scan operator's report, as `wildscan scan` names it.
"""

import math

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty
from bpy.types import PropertyGroup

from ..app.settings import SETTINGS, Limits, default, label, limits, panel_help
from ..blender.generate import DETAILS
from ..core.classes import TAG_NAMES
from ..core.sensors import SensorConfig, device_named, preset_names
from ..core.world.biomes import BIOME_TABLE, BIOMES, DEFAULT_BIOME
from ..core.world.region import DEFAULT_LAYOUT, DEFAULT_REGION, MAX_REGION_SIDE
from ..raycast.select import BACKEND_NAMES
from . import scene as wscene
from .device import DEFAULT_DEVICE_ID, device_from, device_items, take_device_defaults, take_file_defaults
from .weather import CLASSES as WEATHER_CLASSES
from .weather import WildScanEffects, WildScanWeather

_MODEL_TEXT = {
    "paper": "One thin ray a beam; intensity is the class reflectivity (as the paper)",
    "realistic": "The beam's footprint, up to 3 echoes with mixed pixels, physical intensity",
}


def _declared(setting: str, **display) -> dict:
    """A sensor field's name, tooltip, default and slider range from its one declaration
    (app/settings.py), with `display` (precision, step, a narrower slider) on top. The
    slider's range is soft: a value outside it may still be typed, and the Scan operator
    names it as `wildscan scan` does (module docstring). A whole number's lowest is hard."""
    known = SETTINGS[setting]
    fields = dict(name=label(setting), description=panel_help(setting), default=default(setting))
    widest = slider_limits(setting)
    if known.kind is float:
        fields.update(soft_min=widest.low, soft_max=widest.high)
    elif known.kind is int:
        fields.update(min=widest.low)  # the highest (2^63 - 1) is past a Blender int's
    return {**fields, **display}


def slider_limits(setting: str) -> Limits:
    """A sensor field's slider range: every preset's limits (the device menu may choose any)."""
    each = [limits(setting, device_named(name)) for name in preset_names()]
    return Limits(min(x.low for x in each), max(x.high for x in each))


def field_limits(settings) -> dict[str, Limits]:
    """The limits of the numeric sensor fields with the device the settings choose: what the
    Scan operator's check allows (SensorConfig.validate), shown by the panel."""
    device = device_from(settings)
    return {name: limits(name, device) for name in ("rh", "min_range", "max_range", "noise", "divergence")}


def device_limits_text(settings) -> str:
    """One line under the sensor fields: the chosen device's limits ("" while its file cannot
    be read: the panel names why)."""
    from ..core.errors import UserError

    try:
        lim = field_limits(settings)
    except UserError:
        return ""
    return f"r_h {lim['rh'].low:g} to {lim['rh'].high:g} deg, ranges up to {lim['max_range'].high:g} m"


_DETAIL_TEXT = {
    "low": "Fewer, coarser elements: quick to build and scan",
    "default": "The standard world",
    "high": "More, finer elements: slower to build",
}
_FRAME_TEXT = (
    ("leveled", "Leveled", "Origin at the optical centre, Z vertical, X along the heading (as the paper)"),
    ("sensor", "Sensor", "Tilted with the structure, origin at the optical centre"),
    ("world", "World", "Blender's world frame"),
)
_BACKEND_TEXT = {
    "auto": "The fastest available (embree, else open3d, else bvh, else blender)",
    "embree": "Embree through the embreex wheel (fastest)",
    "open3d": "Open3D's RaycastingScene over the extracted triangles",
    "bvh": "mathutils BVH tree over the extracted triangles",
    "blender": "Blender's scene.ray_cast (the reference, slowest)",
}
_BACKEND_LABEL = {"bvh": "BVH", "open3d": "Open3D"}
_STORED = {"pose_x": "_pose_x", "pose_y": "_pose_y", "pose_yaw": "_pose_yaw"}


def _marker(self):
    return wscene.pose_marker(self.id_data) if isinstance(self.id_data, bpy.types.Scene) else None


def _pose_getter(name: str):
    def get(self):
        marker = _marker(self)
        if marker is None:
            return float(self.get(_STORED[name], 0.0))
        x, y, yaw = wscene.marker_pose(marker)
        return {"pose_x": x, "pose_y": y, "pose_yaw": yaw}[name]

    return get


def _pose_setter(name: str):
    def set_(self, value):
        self[_STORED[name]] = float(value)
        marker = _marker(self)
        if marker is None:
            return
        if name == "pose_x":
            marker.location[0] = value
        elif name == "pose_y":
            marker.location[1] = value
        else:
            marker.rotation_euler[2] = math.radians(value)

    return set_


def _view3d_spaces() -> list:
    """The 3D viewports of every open window (none in a background Blender)."""
    wm = bpy.context.window_manager
    windows = wm.windows if wm is not None else []
    return [
        space
        for window in windows
        for area in window.screen.areas
        if area.type == "VIEW_3D"
        for space in area.spaces
        if space.type == "VIEW_3D"
    ]


# "Show world" is display only: it switches the viewports' mesh visibility filter (the
# viewport's Object Types Visibility), which no scan reads. Hiding the world's collection
# (its eye icon) would hide it from the laser too (docs/scanning.md "Which objects a scan sees").
def _get_show_world(self):
    spaces = _view3d_spaces()
    return not spaces or spaces[0].show_object_viewport_mesh


def _set_show_world(self, value):
    for space in _view3d_spaces():
        space.show_object_viewport_mesh = bool(value)


class WildScanSettings(PropertyGroup):
    # World
    seed: IntProperty(
        name=label("seed"), description="World seed: the same seed builds the same world", min=0, default=0
    )
    detail: EnumProperty(
        name=label("detail"),
        description="How detailed the generated world is",
        items=[(d, d.capitalize(), _DETAIL_TEXT.get(d, d)) for d in DETAILS],
        default="default" if "default" in DETAILS else DETAILS[0],
    )
    vegetation: EnumProperty(
        name=label("vegetation"),
        description="How crowns, bushes and high grass are modelled",
        items=[
            (
                "porous",
                "Porous",
                "Branches carrying leaf clusters and separate blades a beam can pass through",
            ),
            ("solid", "Solid", "Closed shells in an open stand: the paper's look"),
        ],
        default="porous",
    )
    biome: EnumProperty(
        name=label("biome"),
        description="The mix of vegetation, ground cover and deadwood (the zones stay the same)",
        items=[
            (b, b.capitalize(), BIOME_TABLE[b].summary[:1].upper() + BIOME_TABLE[b].summary[1:])
            for b in BIOMES
        ],
        default=DEFAULT_BIOME,
    )

    world_layout: EnumProperty(
        name=label("layout"),
        description="Which world the seed gives",
        items=[
            ("endless", "Endless", "A landscape without edges: Generate builds the region below"),
            (
                "paper",
                "Paper",
                "The paper's 150 m island of six zones (with biome Paper: the paper's worlds)",
            ),
        ],
        default=DEFAULT_LAYOUT,
    )
    region_x: FloatProperty(
        name="Centre X", description="Centre of the region of the endless world to build", unit="LENGTH"
    )
    region_y: FloatProperty(
        name="Centre Y", description="Centre of the region of the endless world to build", unit="LENGTH"
    )
    region_size: FloatProperty(
        name="Size",
        description=f"Side of the square region of the endless world to build, at most {MAX_REGION_SIDE:g} m",
        unit="LENGTH",
        min=10.0,
        max=MAX_REGION_SIDE,
        default=DEFAULT_REGION.xmax - DEFAULT_REGION.xmin,
    )

    # Pose
    pose_x: FloatProperty(
        name="X",
        description="Where the robot stands: world X in metres (moves the pose marker)",
        unit="LENGTH",
        get=_pose_getter("pose_x"),
        set=_pose_setter("pose_x"),
    )
    pose_y: FloatProperty(
        name="Y",
        description="Where the robot stands: world Y in metres (moves the pose marker)",
        unit="LENGTH",
        get=_pose_getter("pose_y"),
        set=_pose_setter("pose_y"),
    )
    pose_yaw: FloatProperty(
        name="Yaw",
        description="Heading of the structure's X arm, degrees counter-clockwise from +X",
        precision=1,
        step=500,
        get=_pose_getter("pose_yaw"),
        set=_pose_setter("pose_yaw"),
    )
    use_z_start: BoolProperty(
        name=label("z_start"),
        description="Start the four placement lasers at a given height (e.g. under an overhang or inside the "
        "cave) instead of above the first terrain surface found from above",
        default=False,
    )
    z_start: FloatProperty(
        name="Z",
        description="World height in metres where the placement lasers start",
        unit="LENGTH",
        default=1.0,
    )
    marker: PointerProperty(type=bpy.types.Object, name="Pose marker", options={"HIDDEN"})

    # Sensor
    device: EnumProperty(
        name=label("device"),
        description="The sensor: a preset, or a device file of your own (the fields below take its defaults)",
        items=device_items(),
        default=DEFAULT_DEVICE_ID,
        update=take_device_defaults,
    )
    sensor_file: StringProperty(
        name=label("sensor_file"),
        description="A device file (.toml) written like the presets: beams, timing, ranges, noise, "
        "optics, mount",
        subtype="FILE_PATH",
        update=take_file_defaults,
    )
    # the sliders stop where values are useful; a value past them may still be typed
    rh: FloatProperty(**_declared("rh", soft_max=10.0, precision=2, step=25))
    min_range: FloatProperty(**_declared("min_range", unit="LENGTH"))
    max_range: FloatProperty(**_declared("max_range", unit="LENGTH"))
    mount_height: FloatProperty(**_declared("mount_height", unit="LENGTH", precision=3))
    # the paper model's noise; the realistic model's is the datasheet's unless Datasheet noise is off
    noise: FloatProperty(**_declared("noise", soft_max=0.1, unit="LENGTH", precision=3, step=0.1))
    noise_seed: IntProperty(**_declared("noise_seed"))
    model: EnumProperty(
        name=label("model"),
        description=panel_help("model"),
        items=[(m, m.capitalize(), _MODEL_TEXT[m]) for m in SETTINGS["model"].choices],
        default=SETTINGS["model"].default,
    )
    divergence: FloatProperty(
        **_declared(
            "divergence",
            min=slider_limits("divergence").low,
            max=slider_limits("divergence").high,
            precision=1,
        )
    )
    datasheet_noise: BoolProperty(
        name="Datasheet noise",
        description="Realistic model: the datasheet's range noise (15 mm sigma to 10 m, 25 mm beyond) "
        "instead of the Noise below",
        default=True,
    )
    weather: PointerProperty(type=WildScanWeather, name=label("weather"))  # ui/weather.py
    effects: PointerProperty(type=WildScanEffects, name="Effects")  # ui/weather.py, from the effects table
    frame: EnumProperty(
        name=label("frame"),
        description="Coordinate frame of the exported points",
        items=_FRAME_TEXT,
        default="leveled",
    )

    # Scan
    backend: EnumProperty(
        name=label("backend"),
        description="Which ray caster scans (all give the same labels)",
        items=[(b, _BACKEND_LABEL.get(b, b.capitalize()), _BACKEND_TEXT.get(b, b)) for b in BACKEND_NAMES],
        default="auto",
    )
    keep_previous: BoolProperty(
        name="Keep previous scans",
        description="Keep the clouds of earlier scans instead of replacing them",
        default=False,
    )

    # Result display
    point_size: IntProperty(
        name="Point size",
        description="Size of the cloud's points in the viewport, pixels",
        min=1,
        max=12,
        default=3,
    )
    show_world: BoolProperty(
        name="Show world",
        description="Show the scene's meshes in the 3D viewports (their mesh visibility filter); hide "
        "them to look at the cloud alone. Display only: a scan still sees them",
        get=_get_show_world,
        set=_set_show_world,
    )
    tag_class: EnumProperty(
        name="Class",
        description="The class the Tag buttons give objects (the wildscan_class property)",
        items=[(n, n.capitalize(), f"Tag as {n}") for n in TAG_NAMES],
        default="rock",
    )
    points_in_front: BoolProperty(
        name="In front", description="Draw the cloud's points over the world's surfaces", default=True
    )


CLASSES = (*WEATHER_CLASSES, WildScanSettings)  # a group before the settings that hold it


def attach() -> None:
    bpy.types.Scene.wildscan = PointerProperty(type=WildScanSettings)


def detach() -> None:
    if hasattr(bpy.types.Scene, "wildscan"):
        del bpy.types.Scene.wildscan


def typed_value(value: float) -> float:
    """The number the user typed, from a Blender float property.

    Blender stores float properties (and object locations) in single precision: 0.02
    comes back as 0.0199999995529651. The shortest decimal that single precision maps to
    the same value is what was typed, and what `wildscan scan --noise 0.02` reads, so
    the panel and the command scan with the very same numbers.
    """
    import numpy as np

    return float(str(np.float32(value)))


def sensor_from(settings):
    """The SensorConfig the settings describe (not validated: the caller decides when; a
    sensor file that cannot be used is a UserError already)."""
    realistic = settings.model == "realistic"
    device = device_from(settings)
    return SensorConfig.for_device(
        device,
        rh_deg=typed_value(settings.rh),
        min_range=typed_value(settings.min_range),
        max_range=typed_value(settings.max_range),
        noise_sigma=None if realistic and settings.datasheet_noise else typed_value(settings.noise),
        noise_seed=int(settings.noise_seed),
        model=str(settings.model),
        divergence_mrad=typed_value(settings.divergence) if realistic else device.optics.divergence_mrad,
        mount_height=typed_value(settings.mount_height),
    )


def pose_from(settings):
    from ..core.placement import Pose

    return Pose(typed_value(settings.pose_x), typed_value(settings.pose_y), typed_value(settings.pose_yaw))


def z_start_from(settings) -> float | None:
    return typed_value(settings.z_start) if settings.use_z_start else None
