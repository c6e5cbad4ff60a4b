"""Scan preview PNG: a real image of the right size, class colours where the
points are, near points covering far ones, the bulk of the cloud in view,
deterministic bytes, atomic writes and clear errors for bad paths."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest

from wildscan.core.classes import BY_ID, COLOR_BY_ID
from wildscan.core.errors import UserError
from wildscan.core.pointcloud import PointCloud
from wildscan.viz import preview
from wildscan.viz.preview import legend_entries, nice_length, rasterize, render_preview, view_axes

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SIZE = (640, 480)  # small: fast tests
TERRAIN, TRUNK, FENCE, HIGH_GRASS, WIRE, POLE = 1, 2, 6, 10, 11, 12


def cloud_of(xyz, labels) -> PointCloud:
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    n = len(xyz)
    return PointCloud(
        xyz=xyz,
        intensity=np.zeros(n, np.float32),
        label=np.broadcast_to(np.asarray(labels, dtype=np.uint16), (n,)).copy(),
        instance=np.zeros(n, np.uint32),
        ring=np.zeros(n, np.uint16),
        sweep=np.zeros(n, np.uint16),
        range=np.zeros(n, np.float32),
    )


def cylinder(rng, centre, radius, height, n):
    theta = rng.uniform(0, 2 * np.pi, n)
    return np.c_[
        centre[0] + radius * np.cos(theta), centre[1] + radius * np.sin(theta), rng.uniform(0, height, n)
    ]


def scene(seed: int = 0) -> PointCloud:
    """A ground disc (terrain) with a trunk, a pole and a fence standing on it."""
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(1.0, 100.0, 6000))
    theta = rng.uniform(0, 2 * np.pi, len(r))
    ground = np.c_[r * np.cos(theta), r * np.sin(theta), np.zeros(len(r))]
    t = rng.uniform(0, 1, 800)
    fence = np.c_[-6 + 8 * t, np.full(800, -5.0), rng.uniform(0, 1.0, 800)]
    parts = [
        (ground, TERRAIN),
        (cylinder(rng, (3, 2), 0.3, 4, 800), TRUNK),
        (cylinder(rng, (-3, 3), 0.15, 3, 600), POLE),
        (fence, FENCE),
    ]
    xyz = np.concatenate([p for p, _ in parts])
    labels = np.concatenate([np.full(len(p), lab, np.uint16) for p, lab in parts])
    return cloud_of(xyz, labels)


def plot_region(png_path) -> np.ndarray:
    """(H, W', 3) uint8 pixels left of the legend (legend swatches also carry class colours).

    The legend is the only pure white box in the top right quarter.
    """
    rgb = np.round(mpimg.imread(png_path)[:, :, :3] * 255).astype(np.uint8)
    height, width = rgb.shape[:2]
    quarter = rgb[: height // 2, width // 2 :]
    white_cols = np.nonzero(np.all(quarter == 255, axis=-1).any(axis=0))[0]
    legend_left = width // 2 + int(white_cols[0]) if len(white_cols) else width
    return rgb[:, :legend_left]


def has_colour(pixels: np.ndarray, rgb) -> bool:
    return bool(np.any(np.all(pixels == np.asarray(rgb, np.uint8), axis=-1)))


def colour_fraction(pixels: np.ndarray, rgb) -> float:
    return float(np.mean(np.all(pixels == np.asarray(rgb, np.uint8), axis=-1)))


# --------------------------------------------------------------------------- the image


def test_writes_png_of_requested_size(tmp_path):
    out = render_preview(scene(), tmp_path / "scan.png", title="test scene", size=SIZE)
    assert out == (tmp_path / "scan.png").resolve()
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    assert mpimg.imread(out).shape[:2] == (SIZE[1], SIZE[0])


def test_default_size_is_1200_by_800(tmp_path):
    out = render_preview(scene(), tmp_path / "scan.png")
    assert mpimg.imread(out).shape[:2] == (800, 1200)


@pytest.mark.slow
def test_class_colours_of_the_cloud_appear_where_the_points_are(tmp_path):
    out = render_preview(scene(), tmp_path / "scan.png", size=SIZE)
    pixels = plot_region(out)
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) >= 6
    for class_id in (TERRAIN, TRUNK, FENCE, POLE):
        assert has_colour(pixels, BY_ID[class_id].color), BY_ID[class_id].name
    # Classes absent from the cloud are absent from the picture.
    for class_id in (HIGH_GRASS, WIRE):
        assert not has_colour(pixels, BY_ID[class_id].color), BY_ID[class_id].name


def test_background_is_light_so_black_fence_points_show(tmp_path):
    out = render_preview(scene(), tmp_path / "scan.png", size=SIZE)
    pixels = plot_region(out)
    assert np.all(preview._BACKGROUND_U8 >= 200)
    assert colour_fraction(pixels, preview._BACKGROUND_U8) > 0.3
    assert colour_fraction(pixels, (0, 0, 0)) > 0.001


@pytest.mark.parametrize("near_first", [False, True])
def test_near_points_cover_far_ones(tmp_path, near_first):
    """Two identical squares seen from straight above: only the upper one shows,
    whatever order the points come in."""
    g = np.linspace(-2, 2, 81)
    xx, yy = np.meshgrid(g, g)
    square = np.c_[xx.ravel(), yy.ravel()]
    near = np.c_[square, np.full(len(square), 1.0)]
    far = np.c_[square, np.zeros(len(square))]
    parts = [(near, HIGH_GRASS), (far, WIRE)] if near_first else [(far, WIRE), (near, HIGH_GRASS)]
    xyz = np.concatenate([p for p, _ in parts])
    labels = np.concatenate([np.full(len(p), lab, np.uint16) for p, lab in parts])
    out = render_preview(cloud_of(xyz, labels), tmp_path / "top.png", view_elevation_deg=90.0, size=SIZE)
    pixels = plot_region(out)
    assert colour_fraction(pixels, BY_ID[HIGH_GRASS].color) > 0.2
    assert not has_colour(pixels, BY_ID[WIRE].color)


@pytest.mark.slow
def test_far_stray_points_do_not_shrink_the_view(tmp_path):
    base = scene()
    strays = np.array([[900.0, 0, 0], [-700, 500, 40], [0, -1000, -30], [300, 800, 200]])
    with_strays = cloud_of(np.r_[base.xyz, strays], np.r_[base.label, np.full(4, TERRAIN, np.uint16)])
    a = plot_region(render_preview(base, tmp_path / "a.png", size=SIZE))
    b = plot_region(render_preview(with_strays, tmp_path / "b.png", size=SIZE))
    terrain = BY_ID[TERRAIN].color
    assert colour_fraction(a, terrain) > 0.05
    assert colour_fraction(b, terrain) > 0.8 * colour_fraction(a, terrain)


def test_same_cloud_gives_same_bytes(tmp_path):
    a = render_preview(scene(), tmp_path / "a.png", title="same", size=SIZE)
    b = render_preview(scene(), tmp_path / "b.png", title="same", size=SIZE)
    assert a.read_bytes() == b.read_bytes()
    assert b"Software" not in a.read_bytes()


def test_view_angles_change_the_picture(tmp_path):
    a = render_preview(scene(), tmp_path / "a.png", size=SIZE)
    b = render_preview(scene(), tmp_path / "b.png", view_azimuth_deg=30.0, size=SIZE)
    assert a.read_bytes() != b.read_bytes()


@pytest.mark.slow
def test_empty_cloud_still_writes_an_image(tmp_path):
    out = render_preview(cloud_of(np.zeros((0, 3)), []), tmp_path / "empty.png", title="nothing", size=SIZE)
    pixels = plot_region(out)
    assert mpimg.imread(out).shape[:2] == (SIZE[1], SIZE[0])
    assert not any(has_colour(pixels, BY_ID[i].color) for i in (TERRAIN, TRUNK, POLE, HIGH_GRASS))
    # Some text ("no points", the title) is drawn: more than the flat background.
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 2


@pytest.mark.slow
def test_non_finite_points_are_left_out(tmp_path):
    empty = render_preview(cloud_of(np.zeros((0, 3)), []), tmp_path / "empty.png", size=SIZE)
    nan = render_preview(cloud_of([[np.nan, 0, 0], [0, np.inf, 1]], TRUNK), tmp_path / "nan.png", size=SIZE)
    assert nan.read_bytes() == empty.read_bytes()


def test_single_point_gets_a_frame(tmp_path):
    out = render_preview(cloud_of([[5.0, 5.0, 1.0]], POLE), tmp_path / "one.png", size=SIZE)
    assert has_colour(plot_region(out), BY_ID[POLE].color)


# --------------------------------------------------------------------------- paths and writing


@pytest.mark.parametrize("name", ["scan.jpg", "scan", "scan.png.txt"])
def test_rejects_non_png_suffix(tmp_path, name):
    with pytest.raises(UserError, match=r"\.png"):
        render_preview(scene(), tmp_path / name, size=SIZE)
    assert list(tmp_path.iterdir()) == []


def test_rejects_missing_directory(tmp_path):
    with pytest.raises(UserError, match="does not exist"):
        render_preview(scene(), tmp_path / "nowhere" / "scan.png", size=SIZE)


def test_rejects_a_directory_as_output(tmp_path):
    (tmp_path / "d.png").mkdir()
    with pytest.raises(UserError, match="directory"):
        render_preview(scene(), tmp_path / "d.png", size=SIZE)


@pytest.mark.parametrize("size", [(100, 100), (640,), "big"])
def test_rejects_bad_size(tmp_path, size):
    with pytest.raises(UserError, match="size"):
        render_preview(scene(), tmp_path / "scan.png", size=size)


def test_rejects_bad_elevation(tmp_path):
    with pytest.raises(UserError, match="elevation"):
        render_preview(scene(), tmp_path / "scan.png", view_elevation_deg=120.0, size=SIZE)


def test_replaces_existing_file_and_leaves_no_temp_files(tmp_path):
    out = tmp_path / "scan.png"
    out.write_bytes(b"old")
    render_preview(scene(), out, size=SIZE)
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    assert [p.name for p in tmp_path.iterdir()] == ["scan.png"]


def test_failed_render_keeps_the_old_file(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    out = tmp_path / "scan.png"
    out.write_bytes(b"old")

    def explode(self, *args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(Figure, "savefig", explode)
    with pytest.raises(RuntimeError, match="disk full"):
        render_preview(scene(), out, size=SIZE)
    assert out.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["scan.png"]


# --------------------------------------------------------------------------- pieces


def test_rasterize_square_splats_and_background():
    axes = view_axes(90.0, -90.0)  # straight down, screen right = +X, screen up = +Y
    box = (0.0, 10.0, 0.0, 10.0)  # 1 m per pixel on a 10x10 raster
    xyz = np.array([[2.5, 7.5, 0.0], [7.5, 2.5, 0.0]])
    colors = COLOR_BY_ID[[TRUNK, POLE]]
    image = rasterize(xyz, colors, axes, box, 10, 10, splat=3)
    trunk = np.all(image == colors[0], axis=-1)
    pole = np.all(image == colors[1], axis=-1)
    assert trunk.sum() == 9 and pole.sum() == 9
    assert trunk[1:4, 1:4].all()  # x=2.5 -> column 2, y=7.5 -> row 2 (row 0 at the top)
    assert pole[6:9, 6:9].all()
    assert np.all(image[~(trunk | pole)] == preview._BACKGROUND_U8)


def test_rasterize_drops_points_outside_the_box():
    axes = view_axes(90.0, -90.0)
    image = rasterize(
        np.array([[50.0, 50.0, 0.0]]), COLOR_BY_ID[[TRUNK]], axes, (0.0, 10.0, 0.0, 10.0), 10, 10, 2
    )
    assert np.all(image == preview._BACKGROUND_U8)


def test_view_axes_are_orthonormal_and_screen_right_is_horizontal():
    axes = view_axes(35.0, -60.0)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-12)
    assert axes[0, 2] == 0.0
    assert axes[1, 2] > 0  # world up points up on screen
    assert axes[2, 2] > 0  # the viewer is above the scene


def test_legend_lists_classes_present_with_counts():
    labels = np.array([FENCE, TERRAIN, FENCE, POLE, FENCE], np.uint16)
    assert legend_entries(labels) == [
        ("1 terrain: 1", BY_ID[TERRAIN].color),
        ("6 fence: 3", BY_ID[FENCE].color),
        ("12 pole: 1", BY_ID[POLE].color),
    ]
    assert legend_entries(np.full(12345, TRUNK, np.uint16))[0][0] == "2 trunk: 12,345"


@pytest.mark.parametrize("span, length", [(20.0, 2.0), (30.0, 5.0), (100.0, 20.0), (3.0, 0.5), (51.0, 10.0)])
def test_scale_bar_length_is_a_round_number_near_a_fifth_of_the_view(span, length):
    assert nice_length(span) == pytest.approx(length)
