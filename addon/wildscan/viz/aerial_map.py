"""Aerial map of a planned world (paper Fig. 4): a top view with every class in its
colour tag, zone names, a scale bar and optional scan poses drawn as crosses.

numpy + matplotlib (object API on an Agg canvas: no pyplot, no global state).
Drawn from the plan, so it needs no Blender and no ray casting. Small elements
(poles, trunks, grass) are drawn at least MIN_RADIUS wide so they stay visible.
"""

from __future__ import annotations

import os

import numpy as np

from ..core import detmath as dm
from ..core.classes import CLASSES, class_by_name
from . import require_matplotlib

MIN_RADIUS = 0.35  # m, smallest drawn footprint
WATER_COLOUR = (0.62, 0.78, 0.92)  # water has no colour tag (it returns no point)

# bottom to top
DRAW_ORDER = (
    "low grass",
    "high grass",
    "rock",
    "bush",
    "fence",
    "table",
    "bench",
    "treetop",
    "trunk",
    "wire",
    "pole",
)


def _rgb(name: str) -> tuple[float, float, float]:
    return tuple(c / 255.0 for c in class_by_name(name).color)


def hillshade(z: np.ndarray, spacing: float) -> np.ndarray:
    """Lambert shading for light from the north-west, 45 deg up."""
    gy, gx = np.gradient(z, spacing)
    normal = np.stack([-gx, -gy, np.ones_like(z)], -1)
    normal /= dm.norm(normal)[..., None]  # detmath: the same pixels on every machine
    light = np.array([-1.0, 1.0, 1.4])
    light /= dm.norm(light)
    return np.clip(dm.dot3(normal, light), 0.0, 1.0)


def terrain_image(
    plan, spacing: float = 0.5, extent=None
) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The hill-shaded terrain over `extent` (xmin, xmax, ymin, ymax; default the island's)."""
    from ..core.world import EXTENT
    from ..core.world.terrain_grid import lattice

    xs, ys = lattice(EXTENT if extent is None else extent, spacing)
    gx, gy = np.meshgrid(xs, ys)
    z = plan.ground(gx, gy)
    shade = hillshade(z, spacing)
    base = np.array(_rgb("terrain"))
    height = (z - z.min()) / max(np.ptp(z), 1e-9)
    tone = (0.55 + 0.6 * shade) * (0.85 + 0.3 * height)
    img = np.clip(base[None, None, :] * tone[..., None], 0.0, 1.0)
    if plan.elements_of("water"):
        img[plan.in_water(gx, gy)] = WATER_COLOUR
    return img, (xs[0], xs[-1], ys[0], ys[-1])


def _footprint_polygon(plan, el) -> np.ndarray:
    """Oriented bounding rectangle of the element seen from above (4, 2)."""
    v = plan.prototypes[el.proto].vertices
    lo, hi = v[:, :2].min(0) * el.scale[:2], v[:, :2].max(0) * el.scale[:2]
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    s, c = dm.sincos(el.yaw)
    x, y = corners[:, 0], corners[:, 1]
    return np.column_stack([x * c - y * s, x * s + y * c]) + np.asarray(el.location[:2])


def _laid_meshes(plan) -> list:
    """The elements drawn as their triangles: the trail's flooring, the cave's roof and its
    rock faces (not the terrain itself, which the shaded image is)."""
    return [
        el
        for el in plan.elements
        if el.stage in ("trail", "cave") or (el.stage == "terrain" and el.wildscan_class != "terrain")
    ]


def _wire_line(plan, el) -> np.ndarray:
    v = plan.element_vertices(el)
    sides = plan.detail.wire_sides
    return np.array([v[:sides, :2].mean(0), v[-sides:, :2].mean(0)])


def _extent(extent) -> tuple[float, float, float, float]:
    from ..core.world import EXTENT

    return EXTENT if extent is None else tuple(float(v) for v in extent)


def render_map(plan, path: str, poses=None, dpi: int = 110, title: str | None = None, extent=None) -> str:
    """Write the aerial map PNG of `plan` to `path`; `poses` is an iterable of objects with
    x, y (and optionally yaw_deg) drawn as crosses. `extent` (xmin, xmax, ymin, ymax): the
    area drawn, default the paper island's (a region of the endless world gives its own; a
    plan without zones draws none)."""
    require_matplotlib()
    import matplotlib.patheffects as pe
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import EllipseCollection, LineCollection, PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon, Rectangle

    from ..core.world import ZONES

    EXTENT = _extent(extent)
    fig = Figure(figsize=(10.5, 9.0), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes([0.04, 0.05, 0.74, 0.88])
    img, ext = terrain_image(plan, 0.5 * max(1.0, (EXTENT[1] - EXTENT[0]) / 150.0), EXTENT)
    ax.imshow(img, origin="lower", extent=ext, interpolation="bilinear", zorder=0)

    # flooring and slabs (the trail, the cave's roof and rock faces): their triangles in their
    # class's colour, the roof outlined so it reads as a roof
    for el in _laid_meshes(plan):
        v = plan.element_vertices(el)
        f = plan.prototypes[el.proto].faces
        ax.add_collection(
            PolyCollection(v[f][:, :, :2], facecolors=[_rgb(el.wildscan_class)], edgecolors="none", zorder=2)
        )
        if el.stage == "cave":
            poly = _footprint_polygon(plan, el)
            ax.add_patch(
                Polygon(
                    poly, closed=True, fill=False, edgecolor=(0.25, 0.15, 0.05), lw=1.2, hatch="///", zorder=2
                )
            )
    if plan.layout is not None:
        ax.plot(*plan.layout.trail.path.T, color=(0.3, 0.18, 0.06), lw=0.6, ls=":", zorder=2)

    laid = {id(el) for el in _laid_meshes(plan)}
    for z, cls in enumerate(DRAW_ORDER, start=3):
        els = [el for el in plan.elements_of(cls) if id(el) not in laid]
        if not els:
            continue
        colour = _rgb(cls)
        if cls in ("fence", "table", "bench"):
            polys = [_footprint_polygon(plan, e) for e in els]
            ax.add_collection(
                PolyCollection(polys, facecolors=[colour], edgecolors=[(0.2, 0.2, 0.2)], lw=0.3, zorder=z)
            )
        elif cls == "wire":
            ax.add_collection(
                LineCollection([_wire_line(plan, e) for e in els], colors=[colour], lw=1.0, zorder=z)
            )
        else:
            xy = np.array([e.location[:2] for e in els])
            if cls == "rock":
                w = np.array([max(2 * MIN_RADIUS, 1.0 * e.scale[0]) for e in els])
                h = np.array([max(2 * MIN_RADIUS, 1.0 * e.scale[1] * 0.8) for e in els])
                ang = np.degrees([e.yaw for e in els])
            else:
                least = 0.8 if cls == "pole" else MIN_RADIUS
                w = h = np.array([2 * max(least, e.radius) for e in els])
                ang = np.zeros(len(els))
            alpha = 0.85 if cls == "treetop" else 1.0
            ax.add_collection(
                EllipseCollection(
                    w,
                    h,
                    ang,
                    units="xy",
                    offsets=xy,
                    offset_transform=ax.transData,
                    facecolors=[colour],
                    edgecolors=[(0, 0, 0, 0.35)],
                    linewidths=0.2,
                    alpha=alpha,
                    zorder=z,
                )
            )

    # zones
    halo = [pe.withStroke(linewidth=3, foreground="white")]
    cells = getattr(plan.layout, "cells", None) or {}  # the paper's zones; the endless layout has none
    for name in (z for z in ZONES if z in cells):
        x0, x1, y0, y1 = cells[name]
        ax.add_patch(
            Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ls="--", lw=1.0, ec=(0.1, 0.1, 0.1), zorder=20)
        )
        ax.text(
            x0 + 2,
            y1 - 2,
            name,
            ha="left",
            va="top",
            fontsize=13,
            weight="bold",
            zorder=21,
            path_effects=halo,
        )

    # scan poses
    if poses:
        pts = np.array([[p.x, p.y] for p in poses], dtype=np.float64).reshape(-1, 2)
        ax.scatter(pts[:, 0], pts[:, 1], marker="+", s=140, c="white", linewidths=3.5, zorder=22)
        ax.scatter(pts[:, 0], pts[:, 1], marker="+", s=120, c="black", linewidths=1.5, zorder=23)

    # scale bar, 20 m
    x0, y0 = EXTENT[0] + 5, EXTENT[2] + 5
    ax.add_patch(Rectangle((x0, y0), 20, 1.2, fc="black", ec="white", lw=0.8, zorder=24))
    ax.add_patch(Rectangle((x0 + 10, y0), 10, 1.2, fc="white", ec="black", lw=0.8, zorder=25))
    ax.text(x0 + 10, y0 + 2.2, "20 m", ha="center", va="bottom", fontsize=10, zorder=25, path_effects=halo)

    ax.set_xlim(EXTENT[0], EXTENT[1])
    ax.set_ylim(EXTENT[2], EXTENT[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"WildScan world, seed {plan.seed} ({plan.detail.name} detail)")

    handles = [Patch(facecolor=_rgb("terrain"), edgecolor="k", lw=0.3, label="terrain & flooring")]
    handles += [
        Patch(facecolor=_rgb(c.name), edgecolor="k", lw=0.3, label=c.name)
        for c in CLASSES
        if c.name != "terrain"  # the class table's order, after terrain (drawn above)
    ]
    handles.append(Patch(facecolor=WATER_COLOUR, edgecolor="k", lw=0.3, label="water (no return)"))
    if poses:
        handles.append(Line2D([], [], marker="+", color="black", ls="none", markersize=10, label="scan pose"))
    fig.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.79, 0.93), fontsize=9, frameon=False)

    fig.savefig(path, dpi=dpi, format="png")
    return os.path.abspath(path)
