"""A caster is proven before it is used: a tiny known scene, cast once per process.

Why: a caster that imports can still answer wrongly. Debian's `python3-open3d` (Open3D
0.16.1, linked against Debian's libembree3 3.13.5) misses every ray: Open3D 0.16 sets each
ray's `mask` to 0 (RaycastingScene.cpp, CastRays: `rh.ray.mask = 0`), which Open3D's own
bundled Embree ignores (built without ray masks) but Debian's Embree, built with
EMBREE_RAY_MASK on, honours: a ray whose mask ANDed with the geometry's (0xFFFFFFFF) is 0
skips every geometry. Open3D 0.20's wheel bundles its own Embree and hits. The placement's
four downward lasers are the first rays a scan casts, so such a caster reads as "no terrain
below the pose". Rather than special-casing one version, every caster is asked a
few questions whose answers are known exactly before a scan trusts it.

The scene (metres, a few hundred metres from the world origin as a scan's crop is): a 6 m
square of ground cut into four triangles meeting at its centre (terrain, instance 1), a 2 m
wall of two triangles standing on it (rock, 2) and a small leaf above it (treetop, 3). The
rays: straight down like the placement lasers (onto the shared centre vertex, onto a shared
edge, inside a triangle, onto the leaf, beside the ground), level into the wall, slanting
onto the ground, up into the sky, and straight down with the ground beyond max range. Each
must give its known first hit: hit or miss, class, instance and the float64 distance to
within PROOF_TOLERANCE.

`proof_failure(name, build)` runs the proof of one caster (built by `build`, a function of
a SceneGeometry, or of the scene's triangles for Blender's scene.ray_cast) once per process
and keeps its answer: None when every ray came back right, else one phrase saying what went
wrong (the first wrong ray, and how many were).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.hits import RayHits

# Far above the float64 refinement's error (nanometres at these sizes), far below anything a
# wrong triangle or a float32 distance would be off by on this scene (centimetres to metres).
PROOF_TOLERANCE = 1e-6  # m
PROOF_RANGE = 30.0  # m: the cast range of every proof ray but the one cut at max range
SHORT_RANGE = 5.0  # m: max range of the ray whose ground lies 10 m below
CENTRE = np.array([120.25, -63.5, 4.0])  # where the scene stands in the world

TERRAIN, ROCK, TREETOP = 1, 9, 3  # class ids (core/classes.py, the paper's Table I)
NAMES = {TERRAIN: "terrain", ROCK: "rock", TREETOP: "treetop"}


@dataclass(frozen=True)
class KnownScene:
    """The proof's triangles (T,3,3) world metres, each one's class id, instance and object
    (its index in `objects`, the names a Blender scene gives them), and its rays."""

    triangles: np.ndarray
    class_id: np.ndarray
    instance: np.ndarray
    object_index: np.ndarray
    objects: tuple[str, ...]
    rays: tuple[KnownRay, ...]


@dataclass(frozen=True)
class KnownRay:
    what: str  # how the failure line names the ray
    origin: tuple[float, float, float]  # scene-local metres
    direction: tuple[float, float, float]  # unit
    distance: float  # to its first hit (inf: none within its range)
    class_id: int = 0
    instance: int = -1
    max_range: float = PROOF_RANGE


def known_scene() -> KnownScene:
    g = [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0), (0, 0, 0)]  # ground corners, centre
    ground = [(g[0], g[1], g[4]), (g[1], g[2], g[4]), (g[2], g[3], g[4]), (g[3], g[0], g[4])]
    wall = [((2, -1, 0), (2, 1, 0), (2, 1, 2)), ((2, -1, 0), (2, 1, 2), (2, -1, 2))]
    leaf = [((-2.5, -2.5, 1.5), (-1.5, -2.5, 1.5), (-2, -1.5, 1.5))]
    local = np.array(ground + wall + leaf, dtype=np.float64)
    counts = (len(ground), len(wall), len(leaf))
    down, slant = (0.0, 0.0, -1.0), (float(np.sqrt(0.5)), 0.0, -float(np.sqrt(0.5)))
    rays = (
        KnownRay("straight down onto a vertex four triangles share", (0, 0, 10), down, 10, TERRAIN, 1),
        KnownRay("straight down onto an edge two triangles share", (1, 1, 10), down, 10, TERRAIN, 1),
        KnownRay("straight down onto the ground", (-1, 0.5, 10), down, 10, TERRAIN, 1),
        KnownRay("straight down onto a leaf above the ground", (-2, -2.25, 10), down, 8.5, TREETOP, 3),
        KnownRay("straight down beside the ground", (4, 0, 10), down, np.inf),
        KnownRay("level into a wall", (-1, 0.25, 1), (1.0, 0.0, 0.0), 3, ROCK, 2),
        KnownRay("slanting onto the ground", (-2, -0.5, 3), slant, 3 * float(np.sqrt(2.0)), TERRAIN, 1),
        KnownRay("straight up into the sky", (0.5, 0.5, 1), (0.0, 0.0, 1.0), np.inf),
        KnownRay(
            "straight down, the ground beyond max range", (0.5, -1, 10), down, np.inf, max_range=SHORT_RANGE
        ),
    )
    return KnownScene(
        triangles=local + CENTRE,
        class_id=np.repeat([TERRAIN, ROCK, TREETOP], counts).astype(np.int16),
        instance=np.repeat([1, 2, 3], counts).astype(np.int32),
        object_index=np.repeat([0, 1, 2], counts).astype(np.int32),
        objects=("proof ground", "proof wall", "proof leaf"),
        rays=rays,
    )


def known_geometry(scene: KnownScene):
    """The scene as a SceneGeometry, as extraction would give it."""
    from .geometry import from_triangles

    return from_triangles(scene.triangles, scene.class_id, scene.instance, scene.object_index, scene.objects)


def cast_known(backend, scene: KnownScene) -> list[RayHits]:
    """Each max range's rays cast through `backend` in one call (as a scan casts them)."""
    answers = []
    for max_range in sorted({ray.max_range for ray in scene.rays}):
        rays = [ray for ray in scene.rays if ray.max_range == max_range]
        origins = np.array([ray.origin for ray in rays], dtype=np.float64) + CENTRE
        directions = np.array([ray.direction for ray in rays], dtype=np.float64)
        answers.append((rays, backend.cast(origins, directions, max_range)))
    return answers


def _judged(ray: KnownRay, hits: RayHits, k: int) -> str | None:
    distance = float(hits.distance[k])
    expected = "nothing" if not np.isfinite(ray.distance) else f"{NAMES[ray.class_id]} at {ray.distance:g} m"
    if not np.isfinite(distance):
        return None if not np.isfinite(ray.distance) else f"missed (expected {expected})"
    got = f"hit class {int(hits.class_id[k])} instance {int(hits.instance[k])} at {distance:.6g} m"
    if not np.isfinite(ray.distance):
        return f"{got} (expected {expected})"
    if int(hits.class_id[k]) != ray.class_id or int(hits.instance[k]) != ray.instance:
        return f"{got} (expected {expected})"
    if abs(distance - ray.distance) > PROOF_TOLERANCE:
        return f"{got} (expected {expected})"
    return None


def judge(answers) -> str | None:
    """None when every ray came back right, else the first wrong one and how many were."""
    wrong = []
    total = 0
    for rays, hits in answers:
        total += len(rays)
        wrong += [f"a ray {ray.what} {why}" for k, ray in enumerate(rays) if (why := _judged(ray, hits, k))]
    if not wrong:
        return None
    more = f" ({len(wrong)} of {total} proof rays wrong)" if len(wrong) > 1 else ""
    return wrong[0] + more


_LOCK = threading.Lock()
_PROVEN: dict[str, str | None] = {}


def proof_failure(name: str, build: Callable[[KnownScene], object]) -> str | None:
    """Why caster `name` fails its proof (None: it passed), proven once per process: `build`
    makes the caster over the known scene (it may be a context manager, for casters that need
    a scene of their own), whose answers are then judged. A caster that raises while being
    built or casting fails with what it raised."""
    with _LOCK:
        if name not in _PROVEN:
            _PROVEN[name] = _prove(build)
        return _PROVEN[name]


def forget_proofs() -> None:
    """Prove every caster again at its next use (tests that change what a caster is)."""
    with _LOCK:
        _PROVEN.clear()


def _prove(build) -> str | None:
    scene = known_scene()
    try:
        made = build(scene)
        if hasattr(made, "__enter__"):
            with made as backend:
                return judge(cast_known(backend, scene))
        return judge(cast_known(made, scene))
    except Exception as exc:  # a caster that breaks on a valid scene is refused, not a crash
        return f"it raised {type(exc).__name__}: {exc}".splitlines()[0]
