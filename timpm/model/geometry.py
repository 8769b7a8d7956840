"""Polygon bodies: a slope, an embankment, a layer of ground (2D), and prisms, a polygon
extruded along z (3D).  NumPy only.

A shape gives ``dim``, ``bounds()`` and ``contains(points)``, as :class:`timpm.Box` does;
a :class:`~timpm.Body` fills it with particles on a lattice of ``ppc`` per cell and axis.
The other way round, :func:`deposit_front` reads the shape particles have slid into: the
front of a deposit (the slope demo's run-out, timpm.studies.landslide).
"""
from dataclasses import dataclass

import numpy as np

__all__ = ["Polygon", "Prism", "deposit_front"]


def _orient(a, b, c):
    """The sign of the turn a -> b -> c (arrays of points, (..., 2))."""
    return np.sign((b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
                   - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0]))


#: a segment whose bounding box covers more buckets than this is tested against all
LONG_SEGMENT_BUCKETS = 64
#: the most segment pairs the self-crossing check tests (about 2 s): beyond, refused
MAX_PAIRS = 20_000_000


def _candidate_pairs(p, q, owner="Polygon"):
    """Pairs (i, j), i < j, of segments p_i q_i whose bounding boxes share a bucket of a
    uniform grid (the bucket the typical segment's size), and every pair with a long
    segment: a superset of the crossing pairs, near-linear for an outline such as a
    terrain profile."""
    n = len(p)
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    span = float(np.max(np.ptp(np.concatenate([p, q]), axis=0)))
    size = max(2.0 * float(np.median(np.max(hi - lo, axis=1))), span * 1e-9, 1e-300)
    c0 = np.floor((lo - lo.min(axis=0)) / size).astype(np.int64)
    c1 = np.floor((hi - lo.min(axis=0)) / size).astype(np.int64)
    nx, ny = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
    long = nx * ny > LONG_SEGMENT_BUCKETS
    planned = int(np.count_nonzero(long)) * (n - 1)  # each long edge against every other
    if planned > MAX_PAIRS:
        raise ValueError(f"{owner}: its {n} edges are too long against their spacing to check "
                         f"for crossings within bounds ({int(np.count_nonzero(long))} edges "
                         f"span more than {LONG_SEGMENT_BUCKETS} times the typical edge): "
                         "resample the outline more evenly")
    if int(np.sum((nx * ny)[~long])) > MAX_PAIRS:  # the (bucket, edge) entries
        raise ValueError(f"{owner}: its {n} edges are too many to check for crossings "
                         f"within bounds (more than {MAX_PAIRS} bucket entries): resample the "
                         "outline more coarsely")
    pairs = []
    for i in np.flatnonzero(long):  # few: against every other segment
        others = np.arange(n)
        pairs.append(np.stack([np.full(n - 1, i), np.delete(others, i)], axis=1))
    short = np.flatnonzero(~long)
    counts = (nx * ny)[short]
    seg = np.repeat(short, counts)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(counts) - counts, counts)
    bx = c0[seg, 0] + k % nx[seg]
    by = c0[seg, 1] + k // nx[seg]
    bucket = bx * (int(c1[:, 1].max()) + 1) + by
    order = np.lexsort((seg, bucket))
    bucket, seg = bucket[order], seg[order]
    _, occupancy = np.unique(bucket, return_counts=True)
    if int(np.sum(occupancy * (occupancy - 1) // 2)) + planned > MAX_PAIRS:
        raise ValueError(f"{owner}: its {n} edges crowd together too densely to check for "
                         f"crossings within bounds (up to {int(occupancy.max())} in one "
                         "place): resample the outline more evenly")
    offset = 1
    while True:  # pair each entry with the ones after it in its bucket
        same = bucket[offset:] == bucket[:-offset] if offset < len(bucket) else np.zeros(0, bool)
        if not same.any():
            break
        pairs.append(np.stack([seg[:-offset][same], seg[offset:][same]], axis=1))
        offset += 1
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64)
    out = np.concatenate(pairs)
    return np.unique(np.sort(out, axis=1), axis=0)


def _first_crossing(v, owner="Polygon"):
    """The first pair of edges (i, j) of the closed outline v that properly cross
    (touching ends excluded; neighbours never cross), or None."""
    n = len(v)
    p, q = v, np.roll(v, -1, axis=0)
    ij = _candidate_pairs(p, q, owner)
    i, j = ij[:, 0], ij[:, 1]
    keep = (j - i > 1) & ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]
    cross = ((_orient(p[i], q[i], p[j]) * _orient(p[i], q[i], q[j]) < 0)
             & (_orient(p[j], q[j], p[i]) * _orient(p[j], q[j], q[i]) < 0))
    if not cross.any():
        return None
    k = np.lexsort((j[cross], i[cross]))[0]
    return int(i[cross][k]), int(j[cross][k])


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
    same = np.flatnonzero(np.all(v == np.roll(v, -1, axis=0), axis=1))
    if len(same):
        i = int(same[0])
        raise ValueError(f"{owner} vertices {i} and {(i + 1) % n} coincide at "
                         f"{tuple(map(float, v[i]))}")
    crossing = _first_crossing(v, owner)
    if crossing is not None:
        raise ValueError(f"{owner} edges {crossing[0]} and {crossing[1]} cross: the outline "
                         f"must not intersect itself")
    area = 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
    if abs(area) <= 1e-12 * float(np.ptp(v, axis=0).prod()):
        raise ValueError(f"{owner} encloses no area (its vertices lie on a line)")
    return v, abs(area)


def _inside(vertices, points):
    """Even-odd rule: the points (..., 2) inside the closed polygon (on an edge: the
    region to its right, or above a horizontal one: half-open, as a Box's [lo, hi)).
    A horizontal ray from each point counts the edges it crosses; each edge meets only the
    points in its y range [min, max), found in the points sorted by y, so the work is the
    number of (edge, point) meetings, not edges times points."""
    pts = np.asarray(points, dtype=np.float64)
    shape = pts.shape[:-1]
    pts = pts.reshape(-1, 2)
    x0, y0 = vertices[:, 0], vertices[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    order = np.argsort(pts[:, 1], kind="stable")
    ys = pts[order, 1]
    lo = np.searchsorted(ys, np.minimum(y0, y1), side="left")
    hi = np.searchsorted(ys, np.maximum(y0, y1), side="left")
    counts = hi - lo
    edge = np.repeat(np.arange(len(x0)), counts)
    which = order[np.repeat(lo, counts) + np.arange(counts.sum())
                  - np.repeat(np.cumsum(counts) - counts, counts)]
    px, py = pts[which, 0], pts[which, 1]
    x_cross = x0[edge] + (py - y0[edge]) * (x1[edge] - x0[edge]) / (y1[edge] - y0[edge])
    hits = np.bincount(which[px < x_cross], minlength=len(pts))
    return (hits % 2 == 1).reshape(shape)


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
        # half-open along z as in the plane ([z0, z1)), as a Box: faces shared, filled once
        return _inside(self._v, x[..., :2]) & (x[..., 2] >= self.z[0]) & (x[..., 2] < self.z[1])


def deposit_front(x, h, depth) -> float:
    """The front of a deposit facing +x: the right edge of the last grid column (width
    ``h``, counted from x = 0) where some particle of ``x`` (n, 2) stands ``depth`` high or
    higher; 0 where none does."""
    cols = np.floor(x[:, 0] / h).astype(int)
    shift = min(int(cols.min()), 0)  # (columns left of x = 0 counted from the first)
    top = np.zeros(int(cols.max()) - shift + 1)
    np.maximum.at(top, cols - shift, x[:, 1])
    standing = np.flatnonzero(top >= depth)
    return float((standing.max() + 1 + shift) * h) if len(standing) else 0.0
