"""Polygon bodies: a slope, an embankment, a layer of ground (2D), and prisms, a polygon
extruded along z (3D).  NumPy only.

A shape gives ``dim``, ``bounds()`` and ``contains(points)``, as :class:`timpm.Box` does;
a :class:`~timpm.Body` fills it with particles on a lattice of ``ppc`` per cell and axis.
"""
from dataclasses import dataclass

import numpy as np

__all__ = ["Polygon", "Prism"]


def _segments_cross(p, q, r, s):
    """Whether the closed segments pq and rs properly cross (touching ends excluded)."""
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    return (orient(p, q, r) * orient(p, q, s) < 0) and (orient(r, s, p) * orient(r, s, q) < 0)


def _vertices(owner, value):
    try:
        v = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{owner} vertices must be a list of (x, y) pairs of numbers, got "
                         f"{value!r}") from None
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3:
        raise ValueError(f"{owner} needs at least 3 vertices as (x, y) pairs, got shape "
                         f"{v.shape}")
    if not np.all(np.isfinite(v)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(v), axis=1))[0])
        raise ValueError(f"{owner} vertex {bad} is not finite: {tuple(v[bad])}")
    n = len(v)
    for i in range(n):
        if np.all(v[i] == v[(i + 1) % n]):
            raise ValueError(f"{owner} vertices {i} and {(i + 1) % n} coincide at "
                             f"{tuple(map(float, v[i]))}")
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # neighbours through the closing edge
            if _segments_cross(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]):
                raise ValueError(f"{owner} edges {i} and {j} cross: the outline must not "
                                 f"intersect itself")
    area = 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if abs(area) <= 1e-12 * float(np.ptp(v, axis=0).prod()):
        raise ValueError(f"{owner} encloses no area (its vertices lie on a line)")
    return v, abs(area)


def _inside(vertices, points):
    """Even-odd rule: the points (n, 2) inside the closed polygon (on an edge: either)."""
    x, y = points[..., 0, None], points[..., 1, None]
    x0, y0 = vertices[:, 0], vertices[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    straddles = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return (np.count_nonzero(straddles & (x < x_cross), axis=-1) % 2) == 1


@dataclass(frozen=True)
class Polygon:
    """The region inside a closed outline of ``vertices`` (x, y), in either order, the last
    joined to the first; the outline may not cross itself.  ``area`` is its area."""

    vertices: tuple

    def __post_init__(self):
        v, area = _vertices("Polygon", self.vertices)
        object.__setattr__(self, "vertices", tuple(tuple(map(float, p)) for p in v))
        object.__setattr__(self, "_v", v)
        object.__setattr__(self, "area", area)

    @property
    def dim(self):
        return 2

    def bounds(self):
        return self._v.min(axis=0), self._v.max(axis=0)

    def contains(self, x):
        return _inside(self._v, np.asarray(x, dtype=np.float64))


@dataclass(frozen=True)
class Prism:
    """A :class:`Polygon` in the x-y plane extruded along z from ``z[0]`` to ``z[1]`` (3D;
    y up, so a slope's cross-section extruded across the slope); ``volume`` is its
    volume."""

    vertices: tuple
    z: tuple

    def __post_init__(self):
        v, area = _vertices("Prism", self.vertices)
        try:
            z0, z1 = (float(c) for c in self.z)
        except (TypeError, ValueError):
            raise ValueError(f"Prism z must be (z0, z1), got {self.z!r}") from None
        if not (np.isfinite(z0) and np.isfinite(z1) and z1 > z0):
            raise ValueError(f"Prism z must be (z0, z1) with z1 > z0, got {self.z!r}")
        object.__setattr__(self, "vertices", tuple(tuple(map(float, p)) for p in v))
        object.__setattr__(self, "z", (z0, z1))
        object.__setattr__(self, "_v", v)
        object.__setattr__(self, "volume", area * (z1 - z0))

    @property
    def dim(self):
        return 3

    def bounds(self):
        lo, hi = self._v.min(axis=0), self._v.max(axis=0)
        return np.array([lo[0], lo[1], self.z[0]]), np.array([hi[0], hi[1], self.z[1]])

    def contains(self, x):
        x = np.asarray(x, dtype=np.float64)
        return _inside(self._v, x[..., :2]) & (x[..., 2] >= self.z[0]) & (x[..., 2] <= self.z[1])
