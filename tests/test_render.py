"""The particle renderer: pixel placement, colours, depth order, clipping, GIF output, errors."""
import numpy as np
import pytest

from timpm.output.decorations import (DEFAULT_WIDTH, MAX_WIDTH, MIN_WIDTH, OPEN_SIDE_COLOR,
                                      ROUGH_WALL_COLOR, WALL_COLOR, FrameLayout, check_width,
                                      tick_labels, tick_values)
from timpm.output.render import NAN_COLOR, GifWriter, Movie, Renderer, gif_palette

WHITE = (255, 255, 255)


def drawn(img, background=WHITE):
    """(row, column) of every pixel that is not the background."""
    return [tuple(rc) for rc in np.argwhere((img != np.array(background, np.uint8)).any(axis=-1))]


@pytest.fixture(scope="module")
def box2d():
    # 10 x 5 world units on 100 x 50 pixels: 10 pixels per unit; tiny disks light one pixel
    return Renderer([0.0, 0.0], [10.0, 5.0], width=100, radius=0.4)


def test_size_follows_the_box_aspect_ratio(box2d):
    assert (box2d.width, box2d.height) == (100, 50)
    img = box2d.frame(np.zeros((0, 2)))
    assert img.shape == (50, 100, 3) and img.dtype == np.uint8 and (img == 255).all()
    assert Renderer([0, 0], [1, 1], width=64, height=32).frame(np.zeros((0, 2))).shape == (32, 64, 3)


def test_particle_lights_the_expected_pixel_and_y_points_up(box2d):
    img = box2d.frame(np.array([[2.05, 1.05]]))
    assert drawn(img) == [(50 - 1 - 10, 20)]
    assert tuple(img[39, 20]) == box2d.color
    # higher up in the world is nearer the top of the picture
    assert drawn(box2d.frame(np.array([[2.05, 4.05]]))) == [(50 - 1 - 40, 20)]
    # float32 positions give the same picture
    assert drawn(box2d.frame(np.array([[2.05, 4.05]], np.float32))) == [(9, 20)]


def test_disk_radius_in_pixels():
    r = Renderer([0, 0], [10, 10], width=100, radius=3.0)
    img = r.frame(np.array([[5.0, 5.0]]))       # centre on the corner of four pixels
    rows, cols = np.nonzero((img != 255).any(axis=-1))
    assert rows.min() == 47 and rows.max() == 52 and cols.min() == 47 and cols.max() == 52
    cx = cols + 0.5 - 50.0
    cy = rows + 0.5 - 50.0
    assert (cx ** 2 + cy ** 2 <= 9.0).all() and len(rows) == 32


def test_values_map_through_the_colormap(box2d):
    pos = np.array([[1.05, 1.05], [3.05, 1.05], [5.05, 1.05], [7.05, 1.05]])
    img = box2d.frame(pos, np.array([0.0, 1.0, -7.0, 9.0]), vmin=0.0, vmax=1.0)
    lut = box2d.lut
    assert tuple(img[39, 10]) == tuple(lut[0])      # vmin: first colour
    assert tuple(img[39, 30]) == tuple(lut[-1])     # vmax: last colour
    assert tuple(img[39, 50]) == tuple(lut[0])      # clamped below
    assert tuple(img[39, 70]) == tuple(lut[-1])     # clamped above
    # without vmin/vmax the values' own range is used
    img = box2d.frame(pos[:2], [3.0, 5.0])
    assert tuple(img[39, 10]) == tuple(lut[0]) and tuple(img[39, 30]) == tuple(lut[-1])
    img = box2d.frame(pos[:2], [0.0, 0.5], vmin=0.0, vmax=1.0)
    assert tuple(img[39, 30]) == tuple(lut[128])


def test_other_colormap_and_background():
    r = Renderer([0, 0], [1, 1], width=10, radius=0.4, cmap="plasma", background=(0, 0, 0))
    img = r.frame([[0.55, 0.55], [0.15, 0.15]], [1.0, 0.0])
    assert tuple(img[4, 5]) == tuple(r.lut[-1]) and tuple(img[8, 1]) == tuple(r.lut[0])
    assert tuple(r.lut[0]) != tuple(Renderer([0, 0], [1, 1]).lut[0])
    assert tuple(img[0, 0]) == (0, 0, 0)


def test_nan_value_is_grey(box2d):
    img = box2d.frame([[2.05, 1.05], [4.05, 1.05]], [np.nan, 1.0])
    assert tuple(img[39, 20]) == NAN_COLOR
    assert tuple(img[39, 40]) == tuple(box2d.lut[0])    # the only finite value is vmin
    assert tuple(box2d.frame([[2.05, 1.05]], [np.nan])[39, 20]) == NAN_COLOR


def test_particles_outside_the_box_draw_nothing(box2d):
    out = np.array([[-0.01, 1.0], [10.01, 1.0], [5.0, -0.01], [5.0, 5.01], [1e30, -1e30],
                    [np.nan, 1.0], [1.0, np.inf], [-np.inf, np.nan]])
    img = box2d.frame(out, np.arange(len(out), dtype=float))
    assert drawn(img) == []
    # on the edges and with large disks at the corners: clipped, never out of bounds
    big = Renderer([0.0, 0.0], [10.0, 5.0], width=100, radius=12.0)
    img = big.frame(np.array([[0.0, 0.0], [10.0, 5.0], [10.0, 0.0], [0.0, 5.0]]))
    assert (img[0, 0] != 255).any() and (img[-1, -1] != 255).any() and (img[25, 50] == 255).all()
    img = box2d.frame(np.array([[10.0, 5.0], [0.0, 0.0]]))
    assert sorted(drawn(img)) == [(0, 99), (49, 0)]


def test_nearer_of_two_overlapping_particles_wins_in_3d():
    r = Renderer([0, 0, 0], [1, 1, 1], width=20, radius=2.0)
    lut = r.lut
    near, far = [0.5, 0.5, 1.0], [0.5, 0.5, 0.0]    # axes (0, 1): +z points to the viewer
    for pos, val in (([near, far], [0.0, 1.0]), ([far, near], [1.0, 0.0])):
        img = r.frame(np.array(pos), np.array(val), vmin=0.0, vmax=1.0)
        assert tuple(img[10, 10]) == tuple(lut[0])   # the near particle, drawn at full brightness
    # looking along +y (axes (0, 2)): the smaller y is the nearer
    side = Renderer([0, 0, 0], [1, 1, 1], width=20, radius=2.0, axes=(0, 2))
    img = side.frame(np.array([[0.5, 1.0, 0.5], [0.5, 0.0, 0.5]]), [1.0, 0.0])
    assert tuple(img[10, 10]) == tuple(lut[0])


def test_depth_shading_and_3d_clipping():
    r = Renderer([0, 0, 0], [1, 1, 1], width=20, radius=2.0)
    near = r.frame(np.array([[0.5, 0.5, 1.0]]))[10, 10].astype(int)
    mid = r.frame(np.array([[0.5, 0.5, 0.5]]))[10, 10].astype(int)
    far = r.frame(np.array([[0.5, 0.5, 0.0]]))[10, 10].astype(int)
    assert tuple(near) == r.color
    assert (far <= mid).all() and (mid <= near).all() and far.sum() < mid.sum() < near.sum()
    assert far.sum() > 0.4 * near.sum()          # slightly, not black
    assert drawn(r.frame(np.array([[0.5, 0.5, 1.01], [0.5, 0.5, -0.01]]))) == []


def test_outline_and_timing(box2d):
    before = box2d.seconds
    img = box2d.frame(np.zeros((0, 2)), outline=True)
    assert (img[0] == 0).all() and (img[-1] == 0).all() and (img[:, 0] == 0).all() and (img[:, -1] == 0).all()
    assert (img[1:-1, 1:-1] == 255).all()
    box2d.frame(np.random.default_rng(1).random((1000, 2)) * [10, 5])
    assert box2d.seconds > before


@pytest.mark.parametrize("args,kw,match", [
    (([0, 0], [1, 1, 1]), {}, "2 or 3 coordinates"),
    (([0], [1]), {}, "2 or 3 coordinates"),
    (([0, 0], [1, 0]), {}, "hi > lo"),
    (([0, 0], [1, np.nan]), {}, "hi > lo"),
    (([0, 0], [1, 1]), dict(width=0), "width must be a positive integer"),
    (([0, 0], [1, 1]), dict(width=10.5), "width must be a positive integer"),
    (([0, 0], [1, 1]), dict(height=-2), "height must be a positive integer"),
    (([0, 0], [1, 1]), dict(radius=0.0), "radius must be a positive"),
    (([0, 0], [1, 1]), dict(cmap="no-such-map"), "unknown colormap 'no-such-map'"),
    (([0, 0], [1, 1]), dict(axes=(0, 0)), "axes must be two different"),
    (([0, 0], [1, 1]), dict(axes=(0, 2)), r"indices in 0\.\.1"),
    (([0, 0], [1, 1]), dict(background=(0, 0, 256)), "background must be three integers"),
])
def test_bad_renderer_settings(args, kw, match):
    with pytest.raises(ValueError, match=match):
        Renderer(*args, **kw)


def test_bad_frame_inputs(box2d):
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        box2d.frame(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="one entry per particle"):
        box2d.frame(np.zeros((3, 2)), np.zeros(2))
    with pytest.raises(ValueError, match="vmin <= vmax"):
        box2d.frame(np.zeros((3, 2)), np.zeros(3), vmin=1.0, vmax=0.0)
    with pytest.raises(ValueError, match="need values"):
        box2d.frame(np.zeros((3, 2)), vmin=0.0)


def _frames(n, shape=(30, 40)):
    out = []
    for i in range(n):
        f = np.full(shape + (3,), 255, np.uint8)
        f[:, : 10 * (i + 1)] = (200, 30 * i, 0)
        out.append(f)
    return out


def test_gif_writer(tmp_path):
    from PIL import Image

    path = tmp_path / "anim.gif"
    with GifWriter(path, fps=20, png_dir=tmp_path / "png") as gif:
        for f in _frames(3):
            gif.add(f)
    assert gif.closed and gif.seconds > 0
    with Image.open(path) as im:
        assert im.n_frames == 3 and im.size == (40, 30)
        assert im.info.get("loop") == 0 and im.info.get("duration") == 50
        im.seek(2)
        assert im.convert("RGB").getpixel((25, 5)) == (200, 60, 0)
    pngs = sorted(p.name for p in (tmp_path / "png").iterdir())
    assert pngs == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    with Image.open(tmp_path / "png" / "frame_0001.png") as im:
        assert np.array_equal(np.asarray(im.convert("RGB")), _frames(3)[1])


def test_renderer_frames_into_gif(tmp_path):
    from PIL import Image

    r = Renderer([0, 0], [1, 1], width=32)
    gif = GifWriter(tmp_path / "dots.gif")
    for t in range(4):
        gif.add(r.frame(np.array([[0.2 + 0.2 * t, 0.5]]), [t], vmin=0, vmax=3))
    gif.close()
    with Image.open(tmp_path / "dots.gif") as im:
        assert im.n_frames == 4 and im.size == (32, 32)


def test_bad_gif_use(tmp_path):
    with pytest.raises(ValueError, match=r"\.gif"):
        GifWriter(tmp_path / "anim.png")
    with pytest.raises(ValueError, match="fps must be a positive"):
        GifWriter(tmp_path / "anim.gif", fps=0)
    gif = GifWriter(tmp_path / "anim.gif")
    with pytest.raises(ValueError, match=r"\(height, width, 3\) uint8"):
        gif.add(np.zeros((4, 4, 3)))
    gif.add(np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(ValueError, match="first one's size"):
        gif.add(np.zeros((5, 4, 3), np.uint8))
    with pytest.raises(ValueError, match="no frames were added"):
        GifWriter(tmp_path / "empty.gif").close()
    assert not (tmp_path / "empty.gif").exists()


# ---- movie frames: axes, walls, a colour bar fixed for the run, the time -----------------

@pytest.fixture(scope="module")
def tank():
    """A 2D world with a friction floor and slip walls elsewhere (the column collapse's)."""
    from timpm.scenarios import get_demo

    return get_demo("column-collapse", cells_per_width=6, aspect=1.0).world()


def _movie_frames(path, world, frames, value_range=(0.0, 2.0), **kw):
    """Frames (positions, values, t) through a Movie into ``path``; the movie and the GIF's
    frames decoded to RGB."""
    from PIL import Image

    movie = Movie(path, **kw)
    movie.start(world, "speed", value_range=value_range, label="speed", unit="m/s", title="tank")
    for pos, val, t in frames:
        movie.add(np.asarray(pos, float), np.asarray(val, float), t=t)
    movie.close()
    with Image.open(path) as im:
        decoded = []
        for k in range(im.n_frames):
            im.seek(k)
            decoded.append(np.asarray(im.convert("RGB")))
    return movie, decoded


def _region(img, box):
    x, y, w, h = box
    return img[y:y + h, x:x + w]


def test_movie_frame_is_640_px_wide_with_the_plot_inside(tmp_path, tank):
    movie, gif = _movie_frames(tmp_path / "m.gif", tank, [([[0.1, 0.1]], [1.0], 0.0)])
    layout = movie.layout
    assert movie.width == DEFAULT_WIDTH == 640
    assert gif[0].shape == (layout.height, 640, 3)
    x, y, pw, ph = layout.plot_box
    assert (movie.renderer.width, movie.renderer.height) == (pw, ph)
    assert 0 < x and x + pw < 640 and 0 < y and y + ph < layout.height
    # the plot keeps the domain's aspect ratio: one scale in metres per pixel on both axes
    lx, ly = tank.domain
    assert abs(ph - pw * ly / lx) <= 0.5


def test_walls_are_drawn_along_the_plot(tmp_path, tank):
    movie = Movie(tmp_path / "m.gif")
    movie.start(tank, "speed", value_range=(0.0, 1.0))
    bg = movie.layout.background
    x, y, pw, ph = movie.layout.plot_box
    assert tank.walls[2].kind == "friction" and tank.walls[0].kind == "slip"
    assert tuple(bg[y + ph, x + pw // 2]) == ROUGH_WALL_COLOR     # the floor, below the plot
    assert tuple(bg[y + ph // 2, x - 1]) == WALL_COLOR            # the left wall
    assert tuple(bg[y + ph // 2, x + pw]) == WALL_COLOR           # the right wall
    assert tuple(bg[y - 1, x + pw // 2]) == WALL_COLOR            # the lid
    from timpm.model.world import Ball, Body, World
    from timpm.materials import NeoHookean

    open_top = World(domain=(1.0, 0.5), cells=10, walls={"default": "slip", "top": None},
                     bodies=[Body(Ball((0.5, 0.2), 0.1), NeoHookean(1e3, 0.3, 1e3))])
    movie.start(open_top, "speed", value_range=(0.0, 1.0))
    x, y, pw, ph = movie.layout.plot_box
    assert tuple(movie.layout.background[y - 1, x + pw // 2]) == OPEN_SIDE_COLOR


def test_axes_are_labelled_in_metres(tank):
    layout = FrameLayout(640, (0.0, 0.0), tank.domain, walls=tank.walls)
    ticks = [v for v, _ in layout.x_ticks]
    assert ticks[0] == 0.0 and ticks[-1] <= tank.domain[0] and len(ticks) >= 3
    assert [label for _, label in layout.y_ticks] == tick_labels([v for v, _ in layout.y_ticks])
    assert tick_values(0.0, 3.4, 4) == [0.0, 1.0, 2.0, 3.0]
    assert tick_labels([0.0, 0.25, 0.5]) == ["0.00", "0.25", "0.50"]
    assert tick_labels([-0.2, 0.0, 0.2]) == ["-0.2", "0.0", "0.2"]
    assert tick_labels([0.0, 500.0, 1000.0]) == ["0", "500", "1000"]


def test_colour_range_is_fixed_for_the_run(tmp_path, tank):
    # one particle, slower than the range's top, then faster than it: a range fitted to
    # each frame would draw both in the top colour
    vmax = 2.0
    centre = [[0.5 * tank.domain[0], 0.5 * tank.domain[1]]]
    movie, gif = _movie_frames(tmp_path / "m.gif", tank, [(centre, [0.5 * vmax], 0.0),
                                                          (centre, [3.0 * vmax], 0.01),
                                                          (centre, [0.0], 0.02)], (0.0, vmax))
    assert movie.value_range == (0.0, vmax) and len(gif) == 3
    x, y, pw, ph = movie.layout.plot_box
    at_centre = [f[y + ph // 2, x + pw // 2] for f in gif]
    # the colour bar: the same pixels in every frame, from the colour table's first colour
    # to its last (up to the GIF palette's rounding)
    bars = [_region(f, movie.layout.colorbar_box)[0] for f in gif]
    assert all(np.array_equal(bars[0], b) for b in bars[1:])
    lut = movie.renderer.lut.astype(int)
    assert np.abs(bars[0][[0, -1]] - lut[[0, -1]]).max() <= 4
    # the particle's colour is the bar's at its value: the middle, the top (clamped), 0
    bar = bars[0]
    assert [tuple(c) for c in at_centre] == [tuple(bar[len(bar) // 2]), tuple(bar[-1]), tuple(bar[0])]


def test_time_label_changes_from_frame_to_frame(tmp_path, tank):
    pos = [[0.1, 0.1]]
    movie, gif = _movie_frames(tmp_path / "m.gif", tank, [(pos, [1.0], 0.0), (pos, [1.0], 0.125),
                                                          (pos, [1.0], 0.125)])
    labels = [_region(f, movie.layout.time_box) for f in gif]
    assert not np.array_equal(labels[0], labels[1])
    assert (labels[0] != 255).any()                 # written, not blank
    # Pillow merges identical consecutive frames: the same time gives the same frame
    assert len(gif) == 2
    # outside the plot and the time label, the frames are the background
    outside = np.ones(gif[0].shape[:2], bool)
    for x, y, w, h in (movie.layout.plot_box, movie.layout.time_box):
        outside[y:y + h, x:x + w] = False
    assert np.array_equal(gif[0][outside], gif[1][outside])


@pytest.mark.parametrize("width, match", [
    (319, "at least 320 px"), (8193, "at most 8192 px"), (640.0, "whole number of pixels"),
])
def test_movie_width_is_checked(tmp_path, width, match):
    with pytest.raises(ValueError, match=match):
        Movie(tmp_path / "m.gif", width=width)
    assert check_width(MIN_WIDTH) == MIN_WIDTH and check_width(MAX_WIDTH) == MAX_WIDTH


def test_smallest_width_fits_every_label(tmp_path, tank):
    movie = Movie(tmp_path / "m.gif", width=MIN_WIDTH)
    movie.start(tank, "speed", value_range=(0.0, 14715.0), label="pressure", unit="Pa")
    layout = movie.layout
    tx, _, tw, _ = layout.time_box
    bx, _, bw, _ = layout.colorbar_box
    assert tx + tw < bx and bx + bw < MIN_WIDTH
    assert layout._text_width(f"t = {100:.3f} s") <= tw
    assert layout.plot_box[2] > MIN_WIDTH // 2


def test_movie_needs_a_colour_range_for_values(tmp_path, tank):
    movie = Movie(tmp_path / "m.gif")
    movie.start(tank, "speed")
    with pytest.raises(ValueError, match="needs the run's colour range"):
        movie.add(np.zeros((1, 2)), np.zeros(1), t=0.0)
    movie.add(np.zeros((1, 2)), t=0.0)          # one colour, no colour bar
    assert movie.layout.colorbar_box is None
    with pytest.raises(ValueError, match="finite vmin < vmax"):
        movie.start(tank, "speed", value_range=(1.0, 1.0))


def test_gif_palette_holds_the_extras_greys_and_colour_table():
    lut = Renderer([0, 0], [1, 1]).lut
    extras = [(255, 255, 255), (31, 119, 180)]
    for shades in ((1.0,), (1.0, 0.8, 0.6)):
        pal = gif_palette(lut, extras, shades, greys=24)
        n = (256 - len(extras) - 24) // len(shades)
        assert pal.shape == (len(extras) + 24 + n * len(shades), 3) and len(pal) <= 256
        assert [tuple(c) for c in pal[:2]] == extras
        assert tuple(pal[2]) == (0, 0, 0) and tuple(pal[25]) == (255, 255, 255)
        table = pal[26:26 + n]
        assert tuple(table[0]) == tuple(lut[0]) and tuple(table[-1]) == tuple(lut[-1])
        darkest = pal[-n:]          # the table at the last brightness
        expected = np.round(lut[[0, -1]].astype(float) * shades[-1]).astype(np.uint8)
        assert np.array_equal(darkest[[0, -1]], expected)
