"""What a dataset scan sees of its world (WorldContext): the ray caster over its triangles, the
ground it stands on, the open ground and sky of its bird's-eye grid, its poses. A paper world's is
the whole island, built once per worker (worker.py); an endless world's is made per scan from the
tiles its sensor reaches (land.py)."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ...core.classes import class_by_name
from ...core.errors import UserError
from ...core.posesampler import NoPose
from ...core.truth.open_ground import OpenGround
from ...core.truth.open_sky import open_sky
from ...core.truth.traversability import ROBOT_HEIGHT, traversability_fields
from ...core.world import EXTENT
from ...core.world.cover import CoverGrid
from ...core.world.ground import StandingGround

TERRAIN_ID = class_by_name("terrain").id


@dataclass
class WorldContext:
    seed: int
    backend: object
    poses: list
    instances: np.ndarray | None  # the world's instance ids (None: rank among each scan's own)
    z_range: tuple[float, float]
    open_ground: OpenGround
    build_seconds: float
    # The ground the robot stands on (terrain mesh, trail flooring): what `hag` and the
    # bird's-eye `terrain_z` measure from (core/world/ground.py).
    ground: StandingGround
    cover: CoverGrid | None = None  # the world's ground cover (None: bare ground)
    from_cache: bool = False  # the world was read from the world cache, not built
    sky: OpenGround | None = None  # the world's open sky, when the world cache made it
    extent: tuple[float, float, float, float] = EXTENT  # xmin, xmax, ymin, ymax the bird's-eye grid holds

    def for_scan(self, choice, sensor) -> WorldContext:
        """The world a scan sees: the whole island (an endless world's is its tiles: land.py)."""
        return self

    @functools.cached_property
    def file_numbers(self) -> list[int]:
        """The number in the file names of each scan: its place among the world's scans
        that have a pose. A SemanticKITTI loader (semantic-kitti-api) lists a sequence's
        files sorted and takes line k of poses.txt for the k-th, so a scan without a pose
        must leave no gap: files 000000..N-1, one poses.txt line each, in scan order. The
        poses are the sampler's (the same on every worker), and a pose it kept passed the
        placement the scan runs again, so only a NoPose scan has no files."""
        kept = np.cumsum([not isinstance(p, NoPose) for p in self.poses])
        return [int(n) - 1 for n in kept]

    def traversability(self, x: np.ndarray, y: np.ndarray, z=None) -> dict[str, np.ndarray]:
        """The bird's-eye traversability fields at world points (core/truth/traversability.py); `z`:
        the ground's height there, when known."""
        cover = None if self.cover is None else (lambda px, py: self.cover.at(px, py)[1])
        return traversability_fields(x, y, self.ground, cover, self.cast_up, z)

    @functools.cached_property
    def open_sky(self) -> OpenGround:
        """Where an upward ray from the robot's height meets nothing (core/truth/open_sky.py)."""
        if self.sky is not None:
            return self.sky
        g = self.backend.geometry
        return open_sky(g.vertices, g.faces, self.ground.terrain, ROBOT_HEIGHT, self.extent)

    def cast_up(self, origins: np.ndarray, reach: float) -> np.ndarray:
        """Distance to the first surface straight up from each origin (inf for none): cast,
        but under open sky, where the cast would meet nothing (core/truth/open_sky.py)."""
        distance = np.full(len(origins), np.inf)
        cast = np.flatnonzero(~self.open_sky.contains(origins[:, 0], origins[:, 1]))
        up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (len(cast), 3))
        distance[cast] = self.backend.cast(origins[cast], up, reach).distance
        return distance

    def top_classes(self, origins: np.ndarray, max_range: float) -> np.ndarray:
        """Class of the first surface straight below each origin (0 for none): the terrain
        on open ground (core/truth/open_ground.py), elsewhere cast like every other ray, so the
        float64 settling decides edge hits the same on every CPU."""
        classes = np.full(len(origins), TERRAIN_ID, dtype=np.int16)
        cast = np.flatnonzero(~self.open_ground.contains(origins[:, 0], origins[:, 1]))
        down = np.broadcast_to(np.array([0.0, 0.0, -1.0]), (len(cast), 3))
        classes[cast] = np.maximum(self.backend.first_hit_classes(origins[cast], down, max_range), 0)
        return classes


def embree_backend(geometry, settler=None):
    try:
        from ...raycast.embree_backend import EmbreeBackend

        backend = EmbreeBackend(geometry, settler=settler)
    except ImportError as e:
        raise UserError(f"a dataset worker needs the embreex wheel (pip install embreex): {e}") from None
    backend.threads = 1  # one worker a core: its casts on its own thread (core/runtime/threads.py)
    return backend
