"""Scene geometry as a file: extract a world once, scan it anywhere without Blender.

`extract` turns a world into the numpy triangles every fast backend casts against
(raycast/geometry.py SceneGeometry) and saves them (raycast/scene_file.py): a seed's
world through the Blender-free path (raycast/from_plan.py, no bpy), a .blend file or
the scene Blender has open through extraction (raycast/extract.py, bpy). `scan
--geometry` loads such a file and scans it with embree or bvh; the points equal a scan
of the world it came from, byte for byte.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..core.errors import UserError
from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION

# Backends that cast against SceneGeometry; scene.ray_cast needs the Blender scene itself.
GEOMETRY_BACKENDS = ("auto", "embree", "bvh")


def world_geometry_of(
    world: str | None = None,
    seed: int | None = None,
    detail: str = "default",
    vegetation: str = DEFAULT_VEGETATION,
    quiet: bool = False,
    biome: str = DEFAULT_BIOME,
):
    """(SceneGeometry, metadata) of a world: the world of `seed` at `detail` with
    `vegetation` and `biome` planned without Blender, the .blend file `world` (`quiet`: without
    Blender's "Read blend" line), or (neither) the scene Blender has open."""
    if seed is not None:
        from ..raycast.from_plan import world_geometry

        metadata = {"seed": seed, "detail": detail, "vegetation": vegetation, "world": None}
        if biome != DEFAULT_BIOME:  # the default's metadata keeps its keys
            metadata["biome"] = biome
        return world_geometry(seed, detail, vegetation, biome), metadata
    from ..blender.scene_io import open_world, scene_provenance
    from ..raycast.extract import extract_scene

    if world is not None:
        open_world(world, quiet=quiet)
    scene_seed, blend = scene_provenance()
    return extract_scene(), {"seed": scene_seed, "detail": None, "world": blend}


def extract(
    out: str | os.PathLike,
    world: str | None = None,
    seed: int | None = None,
    detail: str = "default",
    vegetation: str = DEFAULT_VEGETATION,
    quiet: bool = False,
    biome: str = DEFAULT_BIOME,
):
    """Save the geometry of a world (see world_geometry_of) to `out` (.npz); returns
    (path, geometry, metadata). The output path is checked before any work."""
    from ..core.io.files import check_output_path
    from ..raycast.scene_file import SUFFIX, save_geometry

    check_output_path(out, SUFFIX)
    geometry, metadata = world_geometry_of(world, seed, detail, vegetation, quiet, biome)
    return save_geometry(geometry, out, metadata), geometry, metadata


def load_scan_geometry(path: str | os.PathLike, backend: str):
    """(SceneGeometry, metadata) of a geometry file to scan with `backend`; UserError when
    the file cannot be read or the backend needs a Blender scene."""
    from ..raycast.scene_file import load_geometry_file

    if backend not in GEOMETRY_BACKENDS:
        raise UserError(
            f"{backend} needs a Blender scene; a geometry file is scanned with "
            f"{', '.join(GEOMETRY_BACKENDS)}",
            setting="backend",
            allowed=GEOMETRY_BACKENDS,
        )
    geometry, header = load_geometry_file(path)
    metadata = dict(header.get("metadata") or {})
    metadata["geometry"] = str(Path(path).expanduser().resolve())
    return geometry, metadata
