"""Headless particle renderer for 2D and 3D demos, and an animated-GIF writer.

``Renderer`` splats particles as filled disks into an RGB image with one compiled Taichi
kernel (positions and values are passed as NumPy arrays, so every frame reuses it).  In
3D the nearest particle wins each pixel and is shaded slightly darker the farther it is.
``GifWriter`` collects frames and writes them with Pillow; ``Movie`` joins the two into
the sink :func:`timpm.scenarios.demos.run_demo` draws a demo's frames into: each frame
is the particle raster inside axes, walls, a colour bar and the simulated time
(:class:`timpm.output.decorations.FrameLayout`, drawn once; only the time changes).
"""
import numbers
import os
import time
from pathlib import Path

import numpy as np
import taichi as ti

from ..platform.files import replacing
from ..platform.runtime import ensure_init
from .decorations import (DEFAULT_WIDTH, OPEN_SIDE_COLOR, ROUGH_WALL_COLOR, TEXT_COLOR,
                          WALL_COLOR, FrameLayout, check_width)

__all__ = ["Renderer", "GifWriter", "Movie", "colormap_lut", "gif_palette", "check_image"]

_SHIFT = 31                 # depth key = depth level << _SHIFT | reversed particle index
_LEVELS = (1 << 24) - 1     # depth levels across the box
_EMPTY = 1 << 62            # key of a pixel no particle covers
NAN_COLOR = (128, 128, 128)
DEFAULT_COLOR = (31, 119, 180)
DEPTH_SHADE = 0.4           # the farthest particles are drawn at 1 - DEPTH_SHADE brightness


def colormap_lut(name: str) -> np.ndarray:
    """The (256, 3) uint8 colour table of a Matplotlib colormap."""
    import matplotlib

    try:
        cmap = matplotlib.colormaps[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown colormap {name!r}; use a Matplotlib name such as "
                         f"'viridis', 'plasma', 'coolwarm' or 'turbo'") from None
    rgb = cmap(np.linspace(0.0, 1.0, 256))[:, :3]
    return np.ascontiguousarray(np.round(rgb * 255.0).astype(np.uint8))


@ti.func
def _not_finite(x: ti.f64) -> bool:
    # bit test: comparisons with NaN are not reliable under Taichi's fast math
    return (ti.bit_cast(x, ti.i64) >> 52) & 0x7FF == 0x7FF


@ti.func
def _is_nan(x: ti.f64) -> bool:
    bits = ti.bit_cast(x, ti.i64)
    return (bits >> 52) & 0x7FF == 0x7FF and bits & ((ti.i64(1) << 52) - 1) != 0


# slots of the parameter array handed to the kernel
_AX, _AY, _AZ, _TOWARD, _REACH, _RADIUS, _USE_VALUES, _VMIN, _SCALE = range(9)
_LO, _HI, _WIDTH = 9, 12, 15
_N_PARAMS = 16
# rows of the palette after the 256 colormap entries
_PLAIN, _NAN, _BACKGROUND = 256, 257, 258


@ti.kernel
def _rasterise(pos: ti.types.ndarray(ndim=2), val: ti.types.ndarray(ndim=1),
               palette: ti.types.ndarray(dtype=ti.u8, ndim=2), prm: ti.types.ndarray(dtype=ti.f64, ndim=1),
               depth: ti.types.ndarray(dtype=ti.i64, ndim=1), img: ti.types.ndarray(dtype=ti.u8, ndim=1)):
    """Pass 1: each particle atomic-mins its depth key into the pixels of its disk.
    Pass 2: each pixel takes the colour of its winner (or the background) and is reset.
    The depth buffer and the image are flat (rows top to bottom) and the settings come in
    one array: 2D arrays and vector arguments made a frame several times slower."""
    width = ti.cast(prm[_WIDTH], ti.i32)
    height = depth.shape[0] // width
    ax, ay, az = ti.cast(prm[_AX], ti.i32), ti.cast(prm[_AY], ti.i32), ti.cast(prm[_AZ], ti.i32)
    toward, reach = prm[_TOWARD], ti.cast(prm[_REACH], ti.i32)
    lo = ti.Vector([prm[_LO], prm[_LO + 1], prm[_LO + 2]])
    hi = ti.Vector([prm[_HI], prm[_HI + 1], prm[_HI + 2]])
    sx = width / (hi[0] - lo[0])
    sy = height / (hi[1] - lo[1])
    r2 = prm[_RADIUS] * prm[_RADIUS]
    one = ti.i64(1)
    for i in range(pos.shape[0]):
        x = ti.cast(pos[i, ax], ti.f64)
        y = ti.cast(pos[i, ay], ti.f64)
        z = ti.f64(0.0)
        if az >= 0:
            z = ti.cast(pos[i, az], ti.f64)
        inside = not (_not_finite(x) or _not_finite(y) or _not_finite(z))
        if inside:
            inside = lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1] and lo[2] <= z <= hi[2]
        if inside:
            far = ti.f64(0.0)   # 0 nearest the viewer, 1 farthest
            if az >= 0:
                far = (z - lo[2]) / (hi[2] - lo[2])
                if toward > 0:
                    far = 1.0 - far
            level = ti.min(ti.max(ti.cast(far * _LEVELS, ti.i64), 0), _LEVELS)
            key = (level << _SHIFT) | ((one << _SHIFT) - 1 - ti.cast(i, ti.i64))  # ties: later on top
            px = (x - lo[0]) * sx
            py = (y - lo[1]) * sy
            cx = ti.min(ti.cast(ti.floor(px), ti.i32), width - 1)
            cy = ti.min(ti.cast(ti.floor(py), ti.i32), height - 1)
            for r in range(ti.max(cy - reach, 0), ti.min(cy + reach, height - 1) + 1):
                # the columns whose pixel centres lie in the disk on this row (and the
                # particle's own pixel, so that small disks still show)
                ey = r + 0.5 - py
                h2 = r2 - ey * ey
                c0, c1 = cx + 1, cx
                if h2 >= 0.0:
                    w = ti.sqrt(h2)
                    c0 = ti.cast(ti.ceil(px - w - 0.5), ti.i32)
                    c1 = ti.cast(ti.floor(px + w - 0.5), ti.i32)
                if r == cy:
                    c0, c1 = ti.min(c0, cx), ti.max(c1, cx)
                row = (height - 1 - r) * width
                for c in range(ti.max(c0, 0), ti.min(c1, width - 1) + 1):
                    ti.atomic_min(depth[row + c], key)
    use_values, vmin, scale = prm[_USE_VALUES] > 0, prm[_VMIN], prm[_SCALE]
    for p in range(depth.shape[0]):
        key = depth[p]
        k = _BACKGROUND
        shade = ti.f64(1.0)
        if key != ti.i64(_EMPTY):
            depth[p] = ti.i64(_EMPTY)
            k = _PLAIN
            if use_values:
                v = ti.cast(val[(one << _SHIFT) - 1 - (key & ((one << _SHIFT) - 1))], ti.f64)
                k = _NAN
                if not _is_nan(v):
                    t = ti.min(ti.max((v - vmin) * scale, 0.0), 1.0)
                    k = ti.min(ti.cast(t * 256.0, ti.i32), 255)
            if az >= 0:
                shade = 1.0 - DEPTH_SHADE * ti.cast(key >> _SHIFT, ti.f64) / _LEVELS
        for ch in ti.static(range(3)):
            img[3 * p + ch] = ti.cast(palette[k, ch] * shade + 0.5, ti.u8)


def _rgb(name, value):
    try:
        rgb = tuple(int(c) for c in value)
    except (TypeError, ValueError):
        rgb = ()
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise ValueError(f"{name} must be three integers in 0..255 (R, G, B), got {value!r}")
    return rgb


@ti.data_oriented
class Renderer:
    """Draws particles inside the world box ``lo``..``hi`` (2 or 3 coordinates).

    ``axes`` picks the coordinates shown along image x (right) and y (up); in 3D the
    remaining one is depth, and the view is right-handed (it points toward the viewer:
    axes (0, 1) look down -z, axes (0, 2) look along +y).  ``height`` defaults to the
    box's aspect ratio; ``radius`` is the disk radius in pixels; ``color`` is used when
    ``frame`` gets no values.
    """

    def __init__(self, lo, hi, width=480, height=None, radius=1.5, background=(255, 255, 255),
                 cmap="viridis", axes=(0, 1), color=DEFAULT_COLOR):
        ensure_init()
        lo = np.asarray(lo, dtype=np.float64).ravel()
        hi = np.asarray(hi, dtype=np.float64).ravel()
        if lo.size not in (2, 3) or hi.size != lo.size:
            raise ValueError(f"lo and hi must both have 2 or 3 coordinates, got {lo.size} and {hi.size}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            raise ValueError(f"the box needs finite hi > lo in every coordinate, got lo={lo.tolist()}, "
                             f"hi={hi.tolist()}")
        self.dim = lo.size
        try:
            axes = tuple(int(a) for a in axes)
        except (TypeError, ValueError):
            axes = ()
        if len(axes) != 2 or axes[0] == axes[1] or not all(0 <= a < self.dim for a in axes):
            raise ValueError(f"axes must be two different coordinate indices in 0..{self.dim - 1}, "
                             f"got {axes!r}")
        if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
            raise ValueError(f"width must be a positive integer number of pixels, got {width!r}")
        ext = hi - lo
        if height is None:
            height = max(1, int(round(width * ext[axes[1]] / ext[axes[0]])))
        if isinstance(height, bool) or not isinstance(height, (int, np.integer)) or height < 1:
            raise ValueError(f"height must be a positive integer number of pixels, got {height!r}")
        try:
            radius = float(radius)
        except (TypeError, ValueError):
            radius = float("nan")
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"radius must be a positive number of pixels, got {radius!r}")
        check_image(int(width), int(height))
        self.lo, self.hi, self.axes = lo, hi, axes
        self.width, self.height, self.radius = int(width), int(height), float(radius)
        self.background = _rgb("background", background)
        self.color = _rgb("color", color)
        self.cmap = cmap
        self.lut = colormap_lut(cmap)
        self._palette = np.vstack([self.lut, [self.color, NAN_COLOR, self.background]]).astype(np.uint8)
        view = list(axes) + [-1]
        toward = 1
        if self.dim == 3:
            view[2] = 3 - axes[0] - axes[1]
            toward = 1 if tuple(view) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1
        prm = np.zeros(_N_PARAMS)
        prm[[_AX, _AY, _AZ]] = view
        prm[_TOWARD], prm[_REACH], prm[_RADIUS] = toward, np.ceil(self.radius), self.radius
        prm[_LO:_LO + 3] = [lo[a] if a >= 0 else 0.0 for a in view]
        prm[_HI:_HI + 3] = [hi[a] if a >= 0 else 1.0 for a in view]
        prm[_WIDTH] = self.width
        self._params = prm
        self._depth = np.full(self.height * self.width, _EMPTY, dtype=np.int64)
        self._no_values = np.zeros(1, dtype=np.float64)
        self.seconds = 0.0   # cumulative time spent in frame()
        self.frames = 0

    def frame(self, positions, values=None, vmin=None, vmax=None, outline=False) -> np.ndarray:
        """Render particles ``positions`` (n, dim), coloured by ``values`` (n,) through the
        colormap between ``vmin`` and ``vmax`` (default: the finite range of ``values``;
        NaN draws grey), or in one colour without values.  Returns (height, width, 3) uint8."""
        t0 = time.perf_counter()
        pos = np.asarray(positions)
        if pos.ndim != 2 or pos.shape[1] != self.dim:
            raise ValueError(f"positions must have shape (n, {self.dim}) for this {self.dim}D box, "
                             f"got {pos.shape}")
        if pos.shape[0] >= 1 << _SHIFT:
            raise ValueError(f"at most {(1 << _SHIFT) - 1} particles per frame, got {pos.shape[0]}")
        if pos.dtype not in (np.float32, np.float64):
            pos = pos.astype(np.float64)
        pos = np.ascontiguousarray(pos)
        lo_v = hi_v = 0.0
        if values is None:
            val, use_values = self._no_values, 0
            if vmin is not None or vmax is not None:
                raise ValueError("vmin/vmax need values to colour by")
        else:
            val = np.ascontiguousarray(np.asarray(values, dtype=np.float64).ravel())
            if val.size != pos.shape[0]:
                raise ValueError(f"values must have one entry per particle: {val.size} values for "
                                 f"{pos.shape[0]} particles")
            use_values = 1
            if vmin is None or vmax is None:
                finite = val[np.isfinite(val)]
                low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
            lo_v = low if vmin is None else float(vmin)
            hi_v = high if vmax is None else float(vmax)
            if vmin is None:
                lo_v = min(lo_v, hi_v)
            if vmax is None:
                hi_v = max(hi_v, lo_v)
            if not (np.isfinite(lo_v) and np.isfinite(hi_v) and hi_v >= lo_v):
                raise ValueError(f"need finite vmin <= vmax, got vmin={vmin!r}, vmax={vmax!r}")
        flat = np.empty(self.height * self.width * 3, dtype=np.uint8)
        img = flat.reshape(self.height, self.width, 3)
        if pos.shape[0] == 0:
            img[:] = self.background
        else:
            self._params[[_USE_VALUES, _VMIN, _SCALE]] = (
                use_values, lo_v, 1.0 / (hi_v - lo_v) if hi_v > lo_v else 0.0)
            _rasterise(pos, val, self._palette, self._params, self._depth, flat)
        if outline:
            img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = (0, 0, 0)
        self.seconds += time.perf_counter() - t0
        self.frames += 1
        return img


def gif_palette(lut, extras=(), shades=(1.0,), greys=24):
    """At most 256 colours for a GIF: ``extras``, ``greys`` greys from black to white
    (anti-aliased text) and, for each brightness in ``shades``, as many colours of the
    (256, 3) colour table ``lut`` (evenly spaced) as fit.  Returns (n, 3) uint8."""
    extras = np.asarray(extras, dtype=float).reshape(-1, 3)
    n = (256 - len(extras) - greys) // len(shades)
    if n < 2:
        raise ValueError(f"no room for the colour table in 256 colours: {len(extras)} extra "
                         f"colours, {greys} greys, {len(shades)} shades")
    table = np.asarray(lut, dtype=float)[np.round(np.linspace(0, len(lut) - 1, n)).astype(int)]
    ramp = np.repeat(np.linspace(0.0, 255.0, greys)[:, None], 3, axis=1)
    rows = [extras, ramp] + [table * s for s in shades]
    return np.round(np.vstack(rows)).astype(np.uint8)


class GifWriter:
    """Collects RGB frames and writes an animated GIF (looping, ``fps`` frames a second),
    and each frame as ``png_dir/frame_0000.png`` ... when ``png_dir`` is given.

    ``palette`` ((n <= 256, 3) colours, settable before the first frame): every pixel
    takes the nearest of them, without dithering, so that a colour is the same in every
    frame; None: each frame gets its own adaptive palette.  Pillow merges consecutive
    identical frames into one longer frame."""

    def __init__(self, path, fps=25, png_dir=None, palette=None):
        self.path = Path(path)
        if self.path.suffix.lower() != ".gif":
            raise ValueError(f"GifWriter writes .gif files, got {str(path)!r}")
        if isinstance(fps, bool) or not (isinstance(fps, numbers.Real) and np.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.fps = fps
        self.png_dir = Path(png_dir) if png_dir is not None else None
        if self.png_dir is not None:
            os.makedirs(self.png_dir, exist_ok=True)
        self.palette = palette
        self._palette_image = None
        self._frames = []
        self._size = None
        self.closed = False
        self.seconds = 0.0   # cumulative time spent in add() and close()

    def add(self, frame):
        """Append one (height, width, 3) uint8 frame."""
        from PIL import Image

        t0 = time.perf_counter()
        if self.closed:
            raise ValueError("GifWriter is closed")
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
            raise ValueError(f"a frame must be a (height, width, 3) uint8 array, got shape {frame.shape} "
                             f"and dtype {frame.dtype}")
        if self._size is None:
            self._size = frame.shape[:2]
        elif frame.shape[:2] != self._size:
            raise ValueError(f"every frame must have the first one's size {self._size}, got {frame.shape[:2]}")
        image = Image.fromarray(np.ascontiguousarray(frame))
        if self.png_dir is not None:
            # under a unique temporary name, then renamed: Ctrl-C leaves no half frame
            with replacing(self.png_dir / f"frame_{len(self._frames):04d}.png", ".png") as tmp:
                image.save(tmp, format="PNG")
        self._frames.append(self._indexed(image))
        self.seconds += time.perf_counter() - t0

    def _indexed(self, image):
        from PIL import Image

        if self.palette is None:
            return image.convert("P", palette=getattr(Image, "Palette", Image).ADAPTIVE, colors=256)
        if self._palette_image is None:
            colours = np.asarray(self.palette, dtype=np.uint8)
            if colours.ndim != 2 or colours.shape[1] != 3 or not 1 <= len(colours) <= 256:
                raise ValueError(f"a GIF palette is 1 to 256 RGB colours, got shape {colours.shape}")
            self._palette_image = Image.new("P", (1, 1))
            # the unused entries repeat the first colour, so that they are never nearer
            full = np.vstack([colours, np.repeat(colours[:1], 256 - len(colours), axis=0)])
            self._palette_image.putpalette(full.ravel().tolist())
        return image.quantize(palette=self._palette_image, dither=getattr(Image, "Dither", Image).NONE)

    def close(self):
        """Write the GIF (once); refuses when no frame was added."""
        if self.closed:
            return
        if not self._frames:
            raise ValueError(f"no frames were added, so {str(self.path)!r} cannot be written")
        t0 = time.perf_counter()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        first, *rest = self._frames
        with replacing(self.path, ".gif") as tmp:
            first.save(tmp, format="GIF", save_all=True, append_images=rest, loop=0,
                       duration=max(1, int(round(1000.0 / self.fps))), optimize=False)
        self._frames = []
        self.closed = True
        self.seconds += time.perf_counter() - t0

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None or self._frames:
            self.close()
        return False


#: bytes a pixel takes while rendering: the depth key (8) and the RGB image (3)
_PIXEL_BYTES = 8 + 3


def check_image(width: int, height: int, frames: int = 0) -> None:
    """Refuse, before allocating, an image the renderer cannot index (more than 2^31 - 1
    pixels) or whose buffers and ``frames`` kept GIF frames (a byte a pixel) need more
    memory than is available."""
    from ..platform.checks import MAX_INDEX, available_memory

    pixels = width * height
    if pixels > MAX_INDEX:
        raise ValueError(f"an image of {width} x {height} pixels has more than the {MAX_INDEX} "
                         "pixels the renderer can index: choose a smaller width")
    need, free = pixels * (_PIXEL_BYTES + frames), available_memory()
    if free is not None and need > free:
        raise ValueError(f"{frames} frames of {width} x {height} pixels need {need / 1e9:.3g} GB, "
                         f"more than the {free / 1e9:.3g} GB of memory available: choose a "
                         "smaller width or fewer frames")


#: the sea below a still-water level, behind the particles
WATER_COLOR = (205, 226, 245)
#: the ground beyond a plane wall (2D), behind the particles: smooth (slip, roller) and
#: rough (friction, sticky) planes: a slate and a sand, apart from the palette's greys (Pillow
#: maps a colour within a few levels of a grey of the ramp onto that grey)
PLANE_COLOR = (170, 175, 185)
ROUGH_PLANE_COLOR = (215, 185, 150)


def plane_pixels(planes, lo, hi, width, height):
    """The pixels of a (``height``, ``width``) plot of the box ``lo``..``hi`` (2D, rows top
    to bottom) whose centres lie beyond a plane wall, as an (height, width) array of the
    index of the first such plane (-1: none)."""
    xs = lo[0] + (np.arange(width) + 0.5) * (hi[0] - lo[0]) / width
    ys = hi[1] - (np.arange(height) + 0.5) * (hi[1] - lo[1]) / height
    centres = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    which = np.full(len(centres), -1)
    for k, plane in reversed(list(enumerate(planes))):  # the first plane's over the others
        which[plane.distance(centres) > 0.0] = k
    return which.reshape(height, width)


class Movie:
    """A simulation's frames rendered into an animated GIF ``out`` (``width`` pixels wide,
    ``MIN_WIDTH`` to ``MAX_WIDTH`` of :mod:`timpm.output.decorations`; ``fps`` frames a
    second, each frame also as PNG in ``png_dir`` when given).

    ``start(world, color, value_range, label, unit)`` lays the frame out around the
    world's domain (axes in metres, its walls, in 2D the sea below its water level and the
    ground beyond its plane walls, a colour bar from ``value_range`` =
    (vmin, vmax), fixed for the whole run; the colour ``body`` gets a diverging colormap)
    and fits a :class:`Renderer` into its plot; ``add(positions, values, t)`` renders
    and appends one frame with the simulated time ``t``; ``close`` writes the GIF;
    ``seconds`` is the time spent rendering, composing and writing.  ``frames``, the
    frames to come where known, lets ``start`` refuse a movie that would not fit in
    memory before any is drawn."""

    def __init__(self, out, fps=20, width=DEFAULT_WIDTH, png_dir=None, frames=None):
        self.out = str(out)
        self.width = check_width(width)
        self.frames = frames
        self.writer = GifWriter(out, fps=fps, png_dir=png_dir)
        self.renderer = self.layout = self.value_range = None
        self._seconds = 0.0   # laying out and composing frames

    def start(self, world, color=None, value_range=None, label=None, unit="", title=None):
        """Lay the frames of ``world`` out; ``value_range``: the colour range of the whole
        run (None: particles in one colour, no colour bar), its bar labelled ``label``
        (default: ``color``) [``unit``]; ``title`` (default: the world's name)."""
        t0 = time.perf_counter()
        cmap = "viridis" if color != "body" else "coolwarm"
        lut = colormap_lut(cmap)
        colorbar = None
        if value_range is not None:
            colorbar = (lut, *value_range, color if label is None else label, unit)
        lo, hi = (0.0,) * world.dim, world.domain
        # the sea below a still-water level (2D), drawn behind the particles
        water = getattr(world, "water", None)
        level = water.level if world.dim == 2 and water is not None else None
        self.layout = FrameLayout(self.width, lo, hi, walls=world.walls, colorbar=colorbar,
                                  title=world.name if title is None else title)
        if self.frames is not None:
            check_image(self.width, self.layout.height, self.frames)
        _, _, pw, ph = self.layout.plot_box
        self.renderer = Renderer(lo, hi, width=pw, height=ph, cmap=cmap,
                                 radius=max(1.0, 0.8 * pw / world.cells / 2))
        self.water_row = (None if level is None else  # the first pixel row below the level
                          max(0, int(round(ph * (1.0 - level / hi[1])))))
        # the ground beyond the plane walls (2D; in 3D a half-space seen along z has no
        # outline to draw), in each plane's colour
        planes = tuple(getattr(world, "planes", ()) or ()) if world.dim == 2 else ()
        self.plane_fill = None
        if planes:
            which = plane_pixels(planes, lo, hi, pw, ph)
            colours = np.array([ROUGH_PLANE_COLOR if q.kind in ("friction", "sticky")
                                else PLANE_COLOR for q in planes], dtype=np.uint8)
            self.plane_fill = (which >= 0, colours[np.maximum(which, 0)])
        self.value_range = self.layout.value_range
        shades = (1.0,) if world.dim == 2 else (1.0, 1.0 - DEPTH_SHADE / 2, 1.0 - DEPTH_SHADE)
        extras = [self.renderer.background, self.renderer.color, NAN_COLOR, TEXT_COLOR, WALL_COLOR,
                  ROUGH_WALL_COLOR, OPEN_SIDE_COLOR, WATER_COLOR]
        if planes:  # (a scene without planes keeps its colour table's every entry)
            extras += [PLANE_COLOR, ROUGH_PLANE_COLOR]
        self.writer.palette = gif_palette(lut, extras, shades)
        self._seconds += time.perf_counter() - t0

    def add(self, positions, values=None, t=None):
        """Render ``positions`` coloured by ``values`` (through the run's colour range)
        at the simulated time ``t`` [s] and append the frame."""
        if self.renderer is None:
            raise ValueError("Movie.start(world) must come before the first frame")
        if values is not None and self.value_range is None:
            raise ValueError("colouring by values needs the run's colour range: "
                             "Movie.start(world, color, value_range=(vmin, vmax))")
        vmin, vmax = self.value_range if values is not None else (None, None)
        plot = self.renderer.frame(positions, values, vmin=vmin, vmax=vmax)
        if self.water_row is not None or self.plane_fill is not None:
            empty = np.all(plot == self.renderer.background, axis=-1)
        if self.water_row is not None:  # the sea: the empty pixels below the level
            plot[self.water_row:][empty[self.water_row:]] = WATER_COLOR
        if self.plane_fill is not None:  # the ground beyond the planes, over the sea
            beyond, colours = self.plane_fill
            plot[empty & beyond] = colours[empty & beyond]
        t0 = time.perf_counter()
        frame = self.layout.frame(plot, t)
        self._seconds += time.perf_counter() - t0
        self.writer.add(frame)

    def close(self):
        self.writer.close()

    @property
    def seconds(self) -> float:
        rendering = self.renderer.seconds if self.renderer is not None else 0.0
        return self.writer.seconds + rendering + self._seconds
