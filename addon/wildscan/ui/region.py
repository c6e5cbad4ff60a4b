"""The built region of the endless world in the add-on: build it from the World panel's
centre and size, warn when a scan's reach leaves it, and extend it (an operator).

A scan in Blender casts against what the scene holds (either caster), so past the built
region its beams see nothing: the Scan operator says so after the scan (`reach_warning`), and
World > Extend region rebuilds a region that holds the sensor's reach around the pose
(core/world/region.py extended_region), replacing only what WildScan built.
"""

from __future__ import annotations

from bpy.types import Operator

from ..app.settings import panel_message
from .feedback import Progress, internal_error, tag_view3d_redraw


def panel_region(settings):
    """The World panel's region (centre and size) as a checked core/world/region.py Region."""
    from ..core.world.region import check_region, region_around

    return check_region(region_around(settings.region_x, settings.region_y, settings.region_size))


def build_region(seed, region, detail, stage, vegetation, biome) -> None:
    from ..app.world import build_region_in_scene

    build_region_in_scene(seed, region, detail, stage, vegetation=vegetation, biome=biome)


def built_region(scene):
    """The region of the endless world built in the scene (a Region), or None."""
    from ..core.world.region import Region
    from .scene import world_info

    info = world_info(scene)
    return Region(*info["region"]) if info and info.get("region") is not None else None


def sensor_reach(sensor) -> float:
    from ..app.scan import crop_radius

    return crop_radius(sensor)


def reach_warning(scene, pose, sensor) -> str | None:
    """One line when a scan from `pose` reaches past the built region, else None."""
    from ..core.world.region import reach_beyond

    region = built_region(scene)
    if region is None:
        return None
    beyond = reach_beyond(region, pose.x, pose.y, sensor.max_range)
    if beyond <= 0:
        return None
    return (
        f"The sensor reaches {beyond:.0f} m past the built region ({region.text()}): its beams see nothing "
        "there. World > Extend region builds what it reaches"
    )


class WILDSCAN_OT_extend_region(Operator):
    bl_idname = "wildscan.extend_region"
    bl_label = "Extend region"
    bl_description = (
        "Rebuild the endless world's region so it holds the sensor's reach around the pose (replaces only "
        "what WildScan built before)"
    )
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.scene is not None and built_region(context.scene) is not None

    def execute(self, context):
        from ..core.errors import UserError
        from ..core.world.region import extended_region
        from . import status
        from .properties import pose_from, sensor_from

        scene = context.scene
        settings = scene.wildscan
        try:
            pose, sensor = pose_from(settings).validate(), sensor_from(settings).validate()
            region = extended_region(built_region(scene), pose.x, pose.y, sensor_reach(sensor))
            seed = int(settings.seed)
            with Progress(context, f"WildScan: extending the region of seed {seed}") as progress:
                build_region(
                    seed,
                    region,
                    str(settings.detail),
                    progress.stage,
                    str(settings.vegetation),
                    str(settings.biome),
                )
        except UserError as e:
            self.report({"ERROR"}, panel_message(e))
            return {"CANCELLED"}
        except Exception as e:
            return internal_error(self, "extending the region", e)
        finally:
            status.invalidate()
        settings.region_x, settings.region_y = region.centre
        settings.region_size = max(region.size)
        self.report({"INFO"}, f"Built the region {region.text()} of seed {seed}")
        tag_view3d_redraw(context)
        return {"FINISHED"}


CLASSES = (WILDSCAN_OT_extend_region,)
