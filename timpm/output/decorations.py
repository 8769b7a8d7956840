"""The static decorations of a movie frame, drawn once with Pillow.

:class:`FrameLayout` places a plot of the world box (``plot_box``: where the particle
raster goes) among its axes (ticks with labels in metres), the walls along its sides, a
title, a colour bar whose range is fixed for the whole run (labelled with its quantity and
unit) and the slot of the time label.  ``background`` holds everything that does not
change; ``frame(plot, t)`` pastes one particle raster and writes the simulated time.
Text uses Pillow's default font (scalable from Pillow 10.1, a small bitmap font before).
"""
import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

__all__ = ["FrameLayout", "MIN_WIDTH", "MAX_WIDTH", "DEFAULT_WIDTH", "check_width", "tick_values",
           "tick_labels", "TEXT_COLOR", "WALL_COLOR", "ROUGH_WALL_COLOR", "OPEN_SIDE_COLOR"]

#: frame width [px]: the header (title, time, colour bar with its labels) and the axes'
#: labels fit from MIN_WIDTH on; the font grows with the width (1/40 of it, 12 px at least)
MIN_WIDTH, MAX_WIDTH, DEFAULT_WIDTH = 320, 8192, 640
TEXT_COLOR = (0, 0, 0)
WALL_COLOR = (70, 70, 70)            # slip and roller walls
ROUGH_WALL_COLOR = (150, 90, 30)     # friction and sticky walls
OPEN_SIDE_COLOR = (200, 200, 200)    # a side without a wall (material may leave)
_AXIS_NAMES = "xyz"
_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"))


def check_width(width) -> int:
    """``width`` as an int, or a ValueError saying why it cannot be a frame's width."""
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)):
        raise ValueError(f"the movie width must be a whole number of pixels, got {width!r}")
    if width < MIN_WIDTH:
        raise ValueError(f"the movie width must be at least {MIN_WIDTH} px (the axes' labels, the "
                         f"time and the colour bar need it), got {width}")
    if width > MAX_WIDTH:
        raise ValueError(f"the movie width must be at most {MAX_WIDTH} px, got {width}")
    return int(width)


def _font(size):
    try:
        return ImageFont.load_default(size=size)
    except (TypeError, OSError, ImportError):  # Pillow < 10.1 (no size) or no FreeType
        return ImageFont.load_default()


def tick_values(lo, hi, most):
    """At most about ``most`` round values (1, 2, 2.5, 5 times a power of ten) in lo..hi."""
    from matplotlib.ticker import MaxNLocator

    values = MaxNLocator(nbins=max(1, int(most)), steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
    slack = 1e-9 * (hi - lo)
    return [float(v) for v in values if lo - slack <= v <= hi + slack]


def tick_labels(values):
    """Labels of equally spaced tick values, with as many decimals as their step needs."""
    if len(values) < 2:
        return [f"{v:g}" for v in values]
    step = abs(values[1] - values[0])
    mantissa = step / 10.0 ** math.floor(math.log10(step))
    decimals = max(0, -math.floor(math.log10(step) + 1e-9) + (1 if abs(mantissa - 2.5) < 1e-6 else 0))
    out = []
    for v in values:
        text = f"{v:.{decimals}f}"
        out.append(text[1:] if text.startswith("-") and float(text) == 0.0 else text)
    return out


def _scaled_unit(lo, hi, unit):
    """A factor and a prefixed unit (kPa for Pa values in the thousands ...)."""
    top = max(abs(lo), abs(hi))
    if unit.isalpha():
        for factor, prefix in _PREFIXES:
            if top >= factor:
                return factor, prefix + unit
    return 1.0, unit


class FrameLayout:
    """The frame of a ``width``-pixel movie of the box ``lo``..``hi`` seen along ``axes``.

    ``walls``: the world's walls, one (or None) per side in ``timpm.model.SIDES`` order;
    ``colorbar``: (lut, vmin, vmax, label, unit) with the (256, 3) colour table, or None
    for one-colour particles; ``title``: text above the time label."""

    def __init__(self, width, lo, hi, axes=(0, 1), walls=None, colorbar=None, title="",
                 background=(255, 255, 255)):
        self.width = check_width(width)
        self.background_color = tuple(background)
        fs = max(12, round(self.width / 40))
        self.font = _font(fs)
        probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))
        _, top, _, bottom = probe.textbbox((0, 0), "Ag[0.9]", font=self.font)
        self._probe, self._text_top = probe, top
        self.line = bottom - top                     # text line height [px]
        pad, gap = max(4, fs // 2), max(2, fs // 4)
        tick, wall = max(3, fs // 3), max(2, fs // 5)
        self.pad, self.gap, self.tick, self.wall = pad, gap, tick, wall
        ax, ay = axes
        lo_x, hi_x, lo_y, hi_y = float(lo[ax]), float(hi[ax]), float(lo[ay]), float(hi[ay])
        self.x_range, self.y_range = (lo_x, hi_x), (lo_y, hi_y)

        header = pad + 2 * self.line + gap + tick + gap + self.line + pad
        bottom_margin = wall + tick + gap + self.line + gap + self.line + pad
        # the plot's size sets the ticks, whose labels set the margins: two passes settle it
        pw = self.width - 2 * pad
        for _ in range(2):
            ph = max(1, round(pw * (hi_y - lo_y) / (hi_x - lo_x)))
            xt = tick_values(lo_x, hi_x, pw // (6 * fs))
            yt = tick_values(lo_y, hi_y, max(2, ph // (3 * fs)))
            xl, yl = tick_labels(xt), tick_labels(yt)
            wy = max(self._text_width(s) for s in yl)
            wx = max(self._text_width(s) for s in xl)
            left = pad + self.line + gap + wy + gap + tick + wall
            right = wall + pad + (wx + 1) // 2
            pw = self.width - left - right
        ph = max(1, round(pw * (hi_y - lo_y) / (hi_x - lo_x)))   # one scale on both axes
        if pw < 4 * fs:
            raise ValueError(f"a {self.width} px frame leaves {pw} px for the plot: make it wider")
        self.plot_box = (left, header + wall, pw, ph)   # x, y of the top-left corner, width, height
        self.height = header + wall + ph + bottom_margin
        self.x_ticks, self.y_ticks = list(zip(xt, xl)), list(zip(yt, yl))

        image = Image.new("RGB", (self.width, self.height), self.background_color)
        draw = ImageDraw.Draw(image)
        self._draw_axes(image, draw, axes)
        self._draw_walls(draw, axes, walls)
        self._text(draw, (pad, pad), title)
        self.time_box = (pad, pad + self.line + gap, self.width // 2 - pad - gap, self.line)
        self.colorbar_box = None
        self.value_range = None
        if colorbar is not None:
            self._draw_colorbar(draw, *colorbar)
        self.background = np.asarray(image).copy()

    # ---- text -----------------------------------------------------------------------------
    def _text_width(self, text):
        x0, _, x1, _ = self._probe.textbbox((0, 0), text, font=self.font)
        return x1 - x0

    def _text(self, draw, xy, text, fill=TEXT_COLOR):
        """``text`` with its line box's top-left corner at ``xy``."""
        x0, _, _, _ = self._probe.textbbox((0, 0), text, font=self.font)
        draw.text((xy[0] - x0, xy[1] - self._text_top), text, fill=fill, font=self.font)

    def _centred(self, draw, x, y, text):
        self._text(draw, (x - self._text_width(text) // 2, y), text)

    # ---- static parts -------------------------------------------------------------------
    def _px(self, v, lo, hi, n):
        return min(n - 1, max(0, int(math.floor((v - lo) / (hi - lo) * n))))

    def _draw_axes(self, image, draw, axes):
        x, y, pw, ph = self.plot_box
        base = y + ph + self.wall                       # just below the floor line
        for v, label in self.x_ticks:
            c = x + self._px(v, *self.x_range, pw)
            draw.line([(c, base), (c, base + self.tick - 1)], fill=TEXT_COLOR)
            self._centred(draw, c, base + self.tick + self.gap, label)
        self._centred(draw, x + pw // 2, base + self.tick + 2 * self.gap + self.line,
                      f"{_AXIS_NAMES[axes[0]]} [m]")
        edge = x - self.wall - 1                        # just left of the left wall line
        for v, label in self.y_ticks:
            r = y + ph - 1 - self._px(v, *self.y_range, ph)
            draw.line([(edge - self.tick + 1, r), (edge, r)], fill=TEXT_COLOR)
            w = self._text_width(label)
            self._text(draw, (edge - self.tick - self.gap - w, r - self.line // 2), label)
        # the y axis' name, turned a quarter to read upwards
        name = f"{_AXIS_NAMES[axes[1]]} [m]"
        mask = Image.new("L", (self._text_width(name) + 2, self.line + 2), 0)
        self._text(ImageDraw.Draw(mask), (1, 1), name, fill=255)
        mask = mask.rotate(90, expand=True)
        top = y + ph // 2 - mask.size[1] // 2
        image.paste(Image.new("RGB", mask.size, TEXT_COLOR), (self.pad - 1, top), mask)

    def _draw_walls(self, draw, axes, walls):
        """A line along each side of the plot, just outside it: walls dark (rough ones
        brown), sides without a wall light grey."""
        x, y, pw, ph = self.plot_box
        w = self.wall
        sides = {  # rectangle of each side's line, keyed by its index in SIDES
            2 * axes[0]: (x - w, y - w, x - 1, y + ph + w - 1),
            2 * axes[0] + 1: (x + pw, y - w, x + pw + w - 1, y + ph + w - 1),
            2 * axes[1]: (x - w, y + ph, x + pw + w - 1, y + ph + w - 1),
            2 * axes[1] + 1: (x - w, y - w, x + pw + w - 1, y - 1),
        }
        order = sorted(sides, key=lambda k: walls is not None and walls[k] is not None)
        for k in order:   # open sides first, so that walls draw over the shared corners
            wall = walls[k] if walls is not None else None
            if wall is None:
                colour = OPEN_SIDE_COLOR if walls is not None else WALL_COLOR
            else:
                colour = ROUGH_WALL_COLOR if wall.kind in ("friction", "sticky") else WALL_COLOR
            draw.rectangle(sides[k], fill=colour)

    def _draw_colorbar(self, draw, lut, vmin, vmax, label, unit):
        vmin, vmax = float(vmin), float(vmax)
        if not (math.isfinite(vmin) and math.isfinite(vmax) and vmax > vmin):
            raise ValueError(f"the colour bar needs finite vmin < vmax, got {vmin!r}, {vmax!r}")
        factor, unit = _scaled_unit(vmin, vmax, unit)
        lo, hi = vmin / factor, vmax / factor
        end_labels = [f"{lo:.3g}", f"{hi:.3g}"]
        x1 = self.width - self.pad - (self._text_width(end_labels[1]) + 1) // 2
        x0 = self.width // 2
        bar_y = self.pad + self.line + self.gap
        bar_w, bar_h = x1 - x0, self.line
        self._text(draw, (x0, self.pad), f"{label} [{unit}]" if unit else label)
        idx = np.minimum((np.arange(bar_w) + 0.5) / bar_w * 256.0, 255).astype(int)
        for i, k in enumerate(idx):
            draw.line([(x0 + i, bar_y), (x0 + i, bar_y + bar_h - 1)], fill=tuple(int(c) for c in lut[k]))
        self.colorbar_box = (x0, bar_y, bar_w, bar_h)
        self.value_range = (vmin, vmax)
        below = bar_y + bar_h
        marks = [(lo, end_labels[0]), (hi, end_labels[1])]
        inner = [v for v in tick_values(lo, hi, bar_w // (4 * self.line)) if lo < v < hi]
        for v, text in zip(inner, tick_labels(inner) if len(inner) > 1 else [f"{v:.3g}" for v in inner]):
            marks.append((v, text))
        taken = []   # pixel spans of the labels drawn so far: the ends first, then inner ones that fit
        for v, text in marks:
            c = x0 + min(bar_w - 1, int(round((v - lo) / (hi - lo) * (bar_w - 1))))
            w = self._text_width(text)
            span = (c - w // 2 - self.gap, c + w - w // 2 + self.gap)
            if any(span[0] < b and a < span[1] for a, b in taken):
                continue
            taken.append(span)
            draw.line([(c, below), (c, below + self.tick - 1)], fill=TEXT_COLOR)
            self._centred(draw, c, below + self.tick + self.gap // 2, text)

    # ---- per frame ------------------------------------------------------------------------
    def frame(self, plot, t=None) -> np.ndarray:
        """The background with the particle raster ``plot`` (plot_box's size) and, when
        given, the simulated time ``t`` [s]; (height, width, 3) uint8."""
        x, y, pw, ph = self.plot_box
        out = self.background.copy()
        out[y:y + ph, x:x + pw] = plot
        if t is not None:
            out[self._time_rows(), self._time_cols()] = self.time_label(t)
        return out

    def _time_rows(self):
        return slice(self.time_box[1], self.time_box[1] + self.time_box[3])

    def _time_cols(self):
        return slice(self.time_box[0], self.time_box[0] + self.time_box[2])

    def time_label(self, t) -> np.ndarray:
        """The time box's pixels showing ``t = ... s``."""
        _, _, w, h = self.time_box
        image = Image.new("RGB", (w, h), self.background_color)
        self._text(ImageDraw.Draw(image), (0, 0), f"t = {t:.3f} s")
        return np.asarray(image)

