"""The Blender-free path: a world plan straight to the triangles a scan reads (numpy only).

    plan_geometry(plan_world(seed, detail))   ==   extract_scene() after build_world(seed, detail)

`plan_geometry` turns a `WorldPlan` into the `SceneGeometry` (world-space triangles
with per-triangle class, instance and object) that `extract.extract_scene` reads
from the world `world.builder.build_world` realises in an empty Blender scene (the
bpy 5.0 wheel), bit for bit: the same triangles in the same order, the same float64
vertex values, the same object names and local origin. So every scan of it (any
pose, crop and backend over extracted triangles) gives the same PLY bytes as the
Blender path (tests/test_from_plan.py checks seeds, detail levels and poses).
Valid scan poses (`wildscan world`'s sidecar, `wildscan poses`) are found on it;
dataset workers and benchmarks use it where no `bpy` is available or wanted.

Matching Blender exactly takes three things the plan alone does not do:

- Precision. A Blender mesh stores its vertices in float32, and an object's
  world matrix is built in float32 from its float32 location, rotation and scale
  (BKE_object_to_mat4: Euler XYZ angles through double-precision cos/sin, then
  float products). The plan works in float64 (`WorldPlan.triangles`), which
  differs from Blender's world vertices by up to a few micrometres: enough to tilt
  the placement a little and so move every leveled point by up to ~0.7 mm, and
  now and then to gain or lose a point. Here vertices are rounded to float32 and the
  matrix is built with the same float32 operations (`blender_matrices`), then
  applied in float64 by the very expression the extraction uses
  (`geometry.world_vertices`).
- Order. The depsgraph lists objects collection by collection: the builder files
  every element under "WildScan <zone>" > "<zone>: <class>", created in the order
  their first element comes, so objects come zone by zone, class by class, in
  plan order within each (`blender_order`). Triangle order matters: where two
  triangles tie for a ray, the backend reports the one it meets first.
- What is skipped. An object without triangles contributes nothing, not even
  its name (as in extraction).

`WorldPlan.triangles()` stays what it is (the plan's own float64 geometry, in
plan order); this module is the path that equals the Blender scene.
"""

from __future__ import annotations

import numpy as np

from ..core import detmath as dm
from ..core.classes import class_by_name
from ..core.world import DEFAULT_BIOME, plan_world
from .geometry import SceneGeometry, local_origin


def plan_geometry(plan, keep=None) -> SceneGeometry:
    """The scene geometry of a planned world, exactly as extracting it from Blender gives.

    `plan` is a `core.world.WorldPlan` (from `plan_world(seed, detail)`). Returns
    one SceneGeometry of the whole world, uncropped; crop it per pose with
    `geometry.cropped(centre, radius)` or pass it as `geometry=` to
    `raycast.select.make_backend` / `app.scan.scan_current_scene`, which crop the
    same way as the Blender path.

    `keep(elements, matrices)`: a mask of the (ordered) elements to make triangles of, for a
    caller that crops anyway (a drive); the others keep their object index and name but give
    no triangles, so a crop inside the kept ones is the crop of the whole world, byte for byte
    (the offset is then the kept triangles').
    """
    elements = [el for el in blender_order(plan.elements) if len(plan.prototypes[el.proto].faces)]
    matrices = blender_matrices(
        [el.location for el in elements], [el.yaw for el in elements], [el.scale for el in elements]
    )
    chosen = np.ones(len(elements), dtype=bool) if keep is None else keep(elements, matrices)
    geometry = _assembled(plan, elements, matrices, np.flatnonzero(chosen))
    geometry.cover = plan.cover
    return geometry


def _assembled(plan, elements, matrices, chosen) -> SceneGeometry:
    """One SceneGeometry of the `chosen` elements, in order: what geometry.concatenate makes
    of one SceneGeometry per element (the same arrays, bit for bit), written into arrays
    sized once instead of made element by element and joined (~2,000 elements a world)."""
    protos = [plan.prototypes[elements[k].proto] for k in chosen]
    vertex_counts = np.array([len(np.reshape(p.vertices, (-1, 3))) for p in protos], dtype=np.int64)
    triangle_counts = np.array([len(np.reshape(p.faces, (-1, 3))) for p in protos], dtype=np.int64)
    vertex_starts = np.concatenate([[0], np.cumsum(vertex_counts)])
    triangle_starts = np.concatenate([[0], np.cumsum(triangle_counts)])
    if vertex_starts[-1] > np.iinfo(np.int32).max:
        raise ValueError(f"{vertex_starts[-1]} vertices: more than int32 faces can index")
    local: dict[str, np.ndarray] = {}  # meshes are shared: each prototype rounded to float32 once
    for k in chosen:
        name = elements[k].proto
        if name not in local:
            local[name] = (
                np.asarray(plan.prototypes[name].vertices, dtype=np.float32).reshape(-1, 3).astype(np.float64)
            )
    vertices = _moved_vertices(
        [local[elements[k].proto] for k in chosen],
        matrices[np.asarray(chosen, dtype=np.int64)],
        vertex_counts,
    )
    faces = np.empty((int(triangle_starts[-1]), 3), dtype=np.int32)
    if len(protos):
        joined = np.concatenate([np.reshape(p.faces, (-1, 3)) for p in protos]).astype(np.int64)
        joined += np.repeat(vertex_starts[:-1], triangle_counts)[:, None]
        faces[:] = joined
    classes = [class_by_name(elements[k].wildscan_class).id for k in chosen]
    geometry = SceneGeometry(
        vertices=vertices,
        faces=faces,
        class_id=np.repeat(np.array(classes, dtype=np.int16), triangle_counts),
        instance=np.repeat(np.array([elements[k].instance for k in chosen], dtype=np.int32), triangle_counts),
        object_index=np.repeat(np.asarray(chosen, dtype=np.int32), triangle_counts),
        object_names=tuple(el.name for el in elements),
    )
    geometry.offset = local_origin(geometry.vertices, geometry.faces)
    return geometry


def _moved_vertices(locals_: list, matrices: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """(V, 3): each element's float64 local vertices moved by its world matrix, all elements at
    once, bit for bit what world_vertices gives one element at a time: the same products and
    sums in the same order (((m_i0 x + m_i1 y) + m_i2 z) + t_i, detmath's apply by columns)."""
    if not len(counts):
        return np.empty((0, 3))
    stacked = np.concatenate(locals_)
    out = np.empty(stacked.shape)
    columns = [np.ascontiguousarray(stacked[:, k]) for k in range(3)]

    def entry(i: int, j: int) -> np.ndarray:  # matrix entry (i, j) of each vertex's element
        return np.repeat(matrices[:, i, j], counts)

    for i in range(3):
        component = columns[0] * entry(i, 0)
        component += columns[1] * entry(i, 1)
        component += columns[2] * entry(i, 2)
        out[:, i] = component + entry(i, 3)
    return out


def world_geometry(
    seed, detail: str = "default", vegetation: str = "porous", biome: str = DEFAULT_BIOME
) -> SceneGeometry:
    """The scene geometry of the world of `seed` at `detail`, without Blender: what
    `wildscan world --seed S --detail D --vegetation V --biome B` saves, as the scanner sees it."""
    return plan_geometry(plan_world(seed, detail, vegetation=vegetation, biome=biome))


def blender_order(elements) -> list:
    """The plan's elements in the order Blender's depsgraph lists the objects the builder
    makes of them: by zone collection, then class collection (each in the order its
    first element comes), then plan order."""
    groups: dict[str, dict[str, list]] = {}
    for el in elements:
        groups.setdefault(el.zone, {}).setdefault(el.wildscan_class, []).append(el)
    return [el for zone in groups.values() for members in zone.values() for el in members]


def blender_matrices(locations, yaws, scales) -> np.ndarray:
    """(E, 4, 4) float64: the `matrix_world` Blender gives an object with these location,
    Z rotation (radians, rotation mode XYZ) and scale, bit for bit.

    Blender stores the three in float32 and builds the matrix in float32 (the
    rotation from double-precision cos/sin, rounded; then delta rotation times
    rotation, times scale; then the location). Done here with the same operations
    in the same order, so even the signs of zeros agree. The double cos/sin are
    detmath's (< 1 ulp, the same on every CPU; Blender's libm agrees with them once
    rounded to float32 but for one value in ~10^8)."""
    yaw = np.asarray(yaws, dtype=np.float32).reshape(-1)
    count = len(yaw)
    sin, cos = dm.sincos(yaw.astype(np.float64))
    rotation = _euler_z(cos, sin)
    delta = _euler_z(np.ones(count), np.zeros(count))  # the (unused, zero) delta rotation
    scale = np.zeros((count, 3, 3), dtype=np.float32)
    for k in range(3):
        scale[:, k, k] = np.asarray(scales, dtype=np.float32).reshape(-1, 3)[:, k]
    linear = _mul_m3(_mul_m3(delta, rotation), scale)  # [object, column, row]
    out = np.zeros((count, 4, 4), dtype=np.float64)
    out[:, :3, :3] = np.transpose(linear, (0, 2, 1))
    location = np.asarray(locations, dtype=np.float32).reshape(-1, 3)
    out[:, :3, 3] = location + np.float32(0.0)  # plus the (zero) delta location
    out[:, 3, 3] = 1.0
    return out


def _euler_z(cos_z: np.ndarray, sin_z: np.ndarray) -> np.ndarray:
    """Blender's eulO_to_mat3 for order XYZ with X and Y angles 0, from the double cos/sin
    of the Z angle, as (E, 3, 3) float32 [column][row], every product and sum kept (they
    decide the signs of zeros)."""
    count = len(cos_z)
    ci, si = np.ones(count), np.zeros(count)  # X angle 0
    cj, sj = np.ones(count), np.zeros(count)  # Y angle 0
    ch, sh = cos_z, sin_z
    cc, cs, sc, ss = ci * ch, ci * sh, si * ch, si * sh
    m = np.empty((count, 3, 3), dtype=np.float64)
    m[:, 0, 0] = cj * ch
    m[:, 1, 0] = sj * sc - cs
    m[:, 2, 0] = sj * cc + ss
    m[:, 0, 1] = cj * sh
    m[:, 1, 1] = sj * ss + cc
    m[:, 2, 1] = sj * cs - sc
    m[:, 0, 2] = -sj
    m[:, 1, 2] = cj * si
    m[:, 2, 2] = cj * ci
    return m.astype(np.float32)


def _mul_m3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Blender's mul_m3_m3m3(r, a, b) = a·b on [column][row] float32 matrices, summed in
    its order: r[i][j] = b[i][0]·a[0][j] + b[i][1]·a[1][j] + b[i][2]·a[2][j]."""
    r = np.empty_like(a)
    for i in range(3):
        for j in range(3):
            r[:, i, j] = b[:, i, 0] * a[:, 0, j] + b[:, i, 1] * a[:, 1, j] + b[:, i, 2] * a[:, 2, j]
    return r
