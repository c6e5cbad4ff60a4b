"""A PNG preview of a labeled scan: the points in their class colours seen from
an oblique orthographic view, like the paper's Figs. 8-12.

Numpy does the rendering (projection, z-buffer, square splats) into an RGB
array; matplotlib (object-oriented API, Agg backend, never pyplot) only frames
it with a title, a legend of the classes present and a scale bar. A scatter
plot of 800k points would take many seconds; the raster takes a fraction of one.

matplotlib is imported lazily so that importing this module never requires it
(Blender's own Python, for one, does not ship it).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..core import detmath as dm
from ..core.classes import BY_ID
from ..core.errors import UserError
from ..core.io.files import atomic_outputs, user_path
from ..core.pointcloud import PointCloud

_DPI = 100
_BACKGROUND = (0.94, 0.94, 0.94)  # light so black fence points stay visible
_BACKGROUND_U8 = np.array([round(c * 255) for c in _BACKGROUND], dtype=np.uint8)
_CROP_PERCENTILES = (0.5, 99.5)  # the bulk of the points; far strays don't shrink the view
_CROP_MARGIN = 0.03  # fraction of the view span kept around the bulk
_MIN_SPAN_M = 0.5  # a view never narrower than this, so one point still gets a frame
_MIN_PLOT_PX = 64
_HEADER_PX = 64  # title + subtitle band
_FOOTER_PX = 64  # scale bar + axis arrows under the points
_PAD_PX = 8
_MIN_SIZE = (320, 240)
_NO_RANK = np.iinfo(np.int64).max  # z-buffer value of a pixel no point covers


# --------------------------------------------------------------------------- public


def render_preview(
    cloud: PointCloud,
    path: str | os.PathLike,
    title: str = "",
    view_elevation_deg: float = 35.0,
    view_azimuth_deg: float = -60.0,
    size: tuple[int, int] = (1200, 800),
) -> Path:
    """Write a PNG preview of `cloud` to `path` (atomically) and return the path.

    The view looks down at `view_elevation_deg` from the direction
    `view_azimuth_deg` (measured in the XY plane from +X, as in matplotlib's 3D
    axes); Z is up. `size` is (width, height) in pixels.
    """
    out = _check_png_path(path)
    width, height = _check_size(size)
    elevation, azimuth = _check_angles(view_elevation_deg, view_azimuth_deg)
    fig = _build_figure(cloud, title, elevation, azimuth, width, height)
    _save_atomically(fig, out)
    return out


# --------------------------------------------------------------------------- checks


def _check_png_path(path: str | os.PathLike) -> Path:
    out = user_path(path, "preview")
    if out.suffix.lower() != ".png":
        raise UserError(f"cannot write preview {out}: the file name must end in .png")
    if out.is_dir():
        raise UserError(f"cannot write preview {out}: it is a directory; give a file name ending in .png")
    if not out.parent.is_dir():
        raise UserError(f"cannot write preview {out}: directory {out.parent} does not exist")
    return out


def _check_size(size: tuple[int, int]) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in size)
    except (TypeError, ValueError):
        raise UserError(f"preview size must be (width, height) in pixels, got {size!r}") from None
    if width < _MIN_SIZE[0] or height < _MIN_SIZE[1]:
        raise UserError(
            f"preview size must be at least {_MIN_SIZE[0]}x{_MIN_SIZE[1]} pixels, got {width}x{height}"
        )
    return width, height


def _check_angles(elevation_deg: float, azimuth_deg: float) -> tuple[float, float]:
    try:
        elevation_deg, azimuth_deg = float(elevation_deg), float(azimuth_deg)
    except (TypeError, ValueError):
        raise UserError("preview view angles must be numbers of degrees") from None
    if not (math.isfinite(elevation_deg) and math.isfinite(azimuth_deg)):
        raise UserError("preview view angles must be finite numbers")
    if not -90.0 <= elevation_deg <= 90.0:
        raise UserError(f"preview view elevation must be in [-90, 90] degrees, got {elevation_deg}")
    return elevation_deg, azimuth_deg


# --------------------------------------------------------------------------- projection


def view_axes(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """(3,3) rows: screen right, screen up, towards the viewer (world frame, Z up).

    Screen right is always horizontal, so horizontal distances across the image
    are true lengths: that is what makes a scale bar honest in an oblique view.
    """
    (sin_e, cos_e), (sin_a, cos_a) = dm.sincos(dm.radians(elevation_deg)), dm.sincos(dm.radians(azimuth_deg))
    right = (-sin_a, cos_a, 0.0)
    up = (-sin_e * cos_a, -sin_e * sin_a, cos_e)
    toward = (cos_e * cos_a, cos_e * sin_a, sin_e)
    return np.array([right, up, toward], dtype=np.float64)


def _view_box(screen: np.ndarray) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) in metres around the bulk of the projected points."""
    lo = np.percentile(screen, _CROP_PERCENTILES[0], axis=0)
    hi = np.percentile(screen, _CROP_PERCENTILES[1], axis=0)
    centre = (lo + hi) / 2.0
    span = np.maximum(hi - lo, _MIN_SPAN_M) * (1.0 + 2.0 * _CROP_MARGIN)
    return (
        float(centre[0] - span[0] / 2),
        float(centre[0] + span[0] / 2),
        float(centre[1] - span[1] / 2),
        float(centre[1] + span[1] / 2),
    )


def _raster_shape(box: tuple[float, float, float, float], max_w: int, max_h: int) -> tuple[int, int]:
    """(rows, cols) of the largest raster with the box's aspect that fits."""
    dx, dy = box[1] - box[0], box[3] - box[2]
    scale = min(max_w / dx, max_h / dy)
    cols = max(1, min(max_w, int(round(dx * scale))))
    rows = max(1, min(max_h, int(round(dy * scale))))
    return rows, cols


def splat_size(n_points: int, n_pixels: int) -> int:
    """Side of the square splat in pixels: bigger when points are few, so sparse
    scans still read as surfaces; 2 px at least so thin wires and fences show."""
    if n_points <= 0:
        return 2
    return int(np.clip(round(math.sqrt(n_pixels / n_points)), 2, 5))


# --------------------------------------------------------------------------- raster


def rasterize(
    xyz: np.ndarray,
    colors: np.ndarray,
    axes: np.ndarray,
    box: tuple[float, float, float, float],
    rows: int,
    cols: int,
    splat: int,
) -> np.ndarray:
    """(rows, cols, 3) uint8 image, row 0 at the top: each point a splat x splat
    square in its colour, nearer points covering farther ones.

    Z-buffer without a Python loop over points: every point writes its depth
    rank (0 = nearest) into its pixel with np.minimum.at, then a separable
    min-filter grows each pixel into a square, so the nearest splat covering a
    pixel wins. Ties in depth break by point order (stable sort): deterministic.
    """
    image = np.empty((rows, cols, 3), dtype=np.uint8)
    image[:] = _BACKGROUND_U8
    if len(xyz) == 0:
        return image
    proj = dm.apply(axes, xyz)  # detmath: the same pixels on every machine
    x0, x1, y0, y1 = box
    col = np.floor((proj[:, 0] - x0) * (cols / (x1 - x0))).astype(np.int64)
    row = np.floor((y1 - proj[:, 1]) * (rows / (y1 - y0))).astype(np.int64)  # row 0 = top
    inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
    col, row, depth, colors = col[inside], row[inside], proj[inside, 2], colors[inside]
    if len(depth) == 0:
        return image

    nearest_first = np.argsort(-depth, kind="stable")
    rank = np.empty(len(depth), dtype=np.int64)
    rank[nearest_first] = np.arange(len(depth), dtype=np.int64)
    zbuf = np.full(rows * cols, _NO_RANK, dtype=np.int64)
    np.minimum.at(zbuf, row * cols + col, rank)
    zbuf = _min_filter_square(zbuf.reshape(rows, cols), splat)

    covered = zbuf != _NO_RANK
    image[covered] = colors[nearest_first[zbuf[covered]]]
    return image


def _min_filter_square(a: np.ndarray, k: int) -> np.ndarray:
    """Minimum over the k x k window whose top-left corner is (k-1)//2 up-left of each pixel."""
    before, after = (k - 1) // 2, k // 2
    return _min_filter_axis(_min_filter_axis(a, before, after, 0), before, after, 1)


def _min_filter_axis(a: np.ndarray, before: int, after: int, axis: int) -> np.ndarray:
    out = a.copy()
    n = a.shape[axis]
    for shift in range(-after, before + 1):
        if shift == 0 or abs(shift) >= n:
            continue
        dst = [slice(None)] * 2
        src = [slice(None)] * 2
        # A point at index i covers i-before .. i+after, so pixel j takes the point at j+s,
        # -after <= s <= before.
        if shift > 0:
            dst[axis], src[axis] = slice(0, n - shift), slice(shift, n)
        else:
            dst[axis], src[axis] = slice(-shift, n), slice(0, n + shift)
        np.minimum(out[tuple(dst)], a[tuple(src)], out=out[tuple(dst)])
    return out


# --------------------------------------------------------------------------- figure


def _build_figure(cloud: PointCloud, title: str, elev: float, azim: float, width: int, height: int):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI, facecolor=_BACKGROUND)
    canvas = FigureCanvasAgg(fig)
    xyz = np.asarray(cloud.xyz, dtype=np.float64).reshape(-1, 3)
    finite = np.all(np.isfinite(xyz), axis=1)
    labels = np.asarray(cloud.label)[finite]
    xyz = xyz[finite]
    _draw_header(fig, cloud, title, len(xyz), elev, azim, height)
    if len(xyz) == 0:
        fig.text(0.5, 0.45, "no points", ha="center", va="center", fontsize=28, color="0.35")
        return fig

    # The legend's width depends on names and counts: measure it, give the rest to the points.
    legend = _draw_legend(fig, labels, width, height)
    legend_w = int(math.ceil(legend.get_window_extent(canvas.get_renderer()).width))
    plot_w = max(_MIN_PLOT_PX, width - legend_w - 3 * _PAD_PX)
    plot_h = max(_MIN_PLOT_PX, height - _HEADER_PX - _FOOTER_PX - 2 * _PAD_PX)

    axes = view_axes(elev, azim)
    box = _view_box(dm.apply(axes, xyz)[:, :2])
    rows, cols = _raster_shape(box, plot_w, plot_h)
    splat = splat_size(len(xyz), rows * cols)
    image = rasterize(xyz, np.asarray(cloud.colors)[finite], axes, box, rows, cols, splat)

    # Place the axes on whole pixels with the raster's exact size: one raster
    # pixel per output pixel, no resampling blur or dropped rows. The footer
    # strip (scale bar, axis arrows) sits right under it, never over points.
    left = _PAD_PX + (plot_w - cols) // 2
    bottom = _PAD_PX + (plot_h - rows) // 2 + _FOOTER_PX
    ax = fig.add_axes((left / width, bottom / height, cols / width, rows / height))
    ax.imshow(image, extent=box, origin="upper", interpolation="nearest", aspect="auto")
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_axis_off()
    m_per_px = (box[1] - box[0]) / cols
    _draw_scale_bar(ax, box, m_per_px)
    _draw_axis_triad(ax, box, axes, m_per_px)
    return fig


def _draw_header(
    fig, cloud: PointCloud, title: str, n_points: int, elev: float, azim: float, height: int
) -> None:
    top = 1.0 - 10 / height
    fig.text(
        _PAD_PX / fig.bbox.width,
        top,
        title or "WildScan labeled scan",
        ha="left",
        va="top",
        fontsize=15,
        fontweight="bold",
        color="0.1",
    )
    subtitle = (
        f"{n_points:,} points · frame {cloud.frame} · "
        f"orthographic view, elevation {elev:g}°, azimuth {azim:g}°"
    )
    fig.text(
        _PAD_PX / fig.bbox.width, top - 30 / height, subtitle, ha="left", va="top", fontsize=10, color="0.3"
    )


def nice_length(span_m: float) -> float:
    """A 1, 2 or 5 x 10^k length near a fifth of the view width."""
    target = span_m / 5.0
    power = 10.0 ** math.floor(math.log10(target))
    for step in (5.0, 2.0, 1.0):
        if step * power <= target:
            return step * power
    return power


def _format_length(metres: float) -> str:
    if metres >= 1.0:
        return f"{metres:g} m"
    return f"{metres * 100:g} cm"


def _draw_scale_bar(ax, box: tuple[float, float, float, float], m_per_px: float) -> None:
    """A horizontal bar of true length in the strip under the points (screen
    right is horizontal in the world, so image-plane lengths along it are real)."""
    from matplotlib.patches import Rectangle

    x0, x1, y0, _ = box
    length = nice_length(x1 - x0)
    bar_y = y0 - 0.5 * _FOOTER_PX * m_per_px
    ax.add_patch(
        Rectangle(
            (x0, bar_y - 2 * m_per_px),
            length,
            4 * m_per_px,
            facecolor="0.15",
            edgecolor="none",
            clip_on=False,
        )
    )
    for end in (x0, x0 + length):  # end ticks make the bar read as a measure, not a line
        ax.add_patch(
            Rectangle(
                (end - m_per_px, bar_y - 6 * m_per_px),
                2 * m_per_px,
                12 * m_per_px,
                facecolor="0.15",
                edgecolor="none",
                clip_on=False,
            )
        )
    ax.text(
        x0 + length + 8 * m_per_px,
        bar_y,
        _format_length(length),
        ha="left",
        va="center",
        fontsize=10,
        color="0.15",
        clip_on=False,
    )


def _draw_axis_triad(ax, box: tuple[float, float, float, float], axes: np.ndarray, m_per_px: float) -> None:
    """Little world X/Y/Z arrows in the strip under the points, so the view direction is readable."""
    x0, x1, y0, _ = box
    arm = 22 * m_per_px
    ox, oy = x1 - 40 * m_per_px, y0 - 0.5 * _FOOTER_PX * m_per_px
    for name, world, color in (
        ("X", (1, 0, 0), "#c0392b"),
        ("Y", (0, 1, 0), "#27ae60"),
        ("Z", (0, 0, 1), "#2e5cb8"),
    ):
        dx, dy = dm.dot3(axes[0], world), dm.dot3(axes[1], world)
        if dm.hypot(dx, dy) < 0.15:  # pointing at the viewer: an arrow would be a dot
            continue
        ax.annotate(
            "",
            xy=(ox + arm * dx, oy + arm * dy),
            xytext=(ox, oy),
            annotation_clip=False,
            arrowprops={
                "arrowstyle": "-|>",
                "color": color,
                "lw": 1.5,
                "mutation_scale": 10,
                "shrinkA": 0,
                "shrinkB": 0,
            },
        )
        ax.text(
            ox + 1.35 * arm * dx,
            oy + 1.35 * arm * dy,
            name,
            ha="center",
            va="center",
            fontsize=8,
            color=color,
            fontweight="bold",
            clip_on=False,
        )


def legend_entries(labels: np.ndarray) -> list[tuple[str, tuple[int, int, int]]]:
    """(text, rgb) for each class present, by id: "5 bush: 1,234" and its colour tag."""
    ids, counts = np.unique(np.asarray(labels), return_counts=True)
    entries = []
    for class_id, count in zip(ids.tolist(), counts.tolist()):
        element = BY_ID.get(class_id)
        name = element.name if element else "unknown"
        rgb = element.color if element else (255, 0, 255)
        entries.append((f"{class_id} {name}: {count:,}", rgb))
    return entries


def _draw_legend(fig, labels: np.ndarray, width: int, height: int):
    from matplotlib.lines import Line2D

    handles = [
        Line2D(
            [],
            [],
            linestyle="none",
            marker="s",
            markersize=11,
            markerfacecolor=tuple(c / 255 for c in rgb),
            markeredgecolor="0.35",
            markeredgewidth=0.6,
            label=text,
        )
        for text, rgb in legend_entries(labels)
    ]
    anchor = (1.0 - _PAD_PX / width, 1.0 - (_HEADER_PX + _PAD_PX) / height)
    legend = fig.legend(
        handles=handles,
        loc="upper right",
        bbox_to_anchor=anchor,
        title="class: points",
        fontsize=9,
        title_fontsize=10,
        frameon=True,
        framealpha=1.0,
        facecolor="white",
        edgecolor="0.7",
        handletextpad=0.4,
        borderpad=0.7,
        labelspacing=0.5,
    )
    legend.set_alignment("left")
    return legend


# --------------------------------------------------------------------------- writing


def _save_atomically(fig, out: Path) -> None:
    """Render to a temp file beside `out`, then rename: never a half-written PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    with atomic_outputs(out) as (tmp,):
        # No Software/date text: the same cloud gives the same bytes.
        fig.savefig(tmp, format="png", dpi=_DPI, facecolor=fig.get_facecolor(), metadata={"Software": None})
