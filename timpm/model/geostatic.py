"""Initial stresses of ground at rest: the K0 procedure.  NumPy only.

The vertical stress at a point is the weight of the material above it, sigma_v(x, y) =
g int_y^top rho(x, s) ds, through every body over the point (layers of different unit
weight, a sloping surface); the horizontal stresses are K0 sigma_v.  Compression is
negative: sigma_yy = -sigma_v, sigma_xx = sigma_zz = -K0 sigma_v (sigma_zz the
out-of-plane stress of plane strain in 2D), no shear.  K0 is given, or Jaky's 1 - sin(phi)
of each particle's material (nu / (1 - nu) for a material without friction).

On a sloping surface this is the K0 procedure of finite-element practice: not in
equilibrium near the slope (the shear the slope needs is missing), so a slope starts with
small motions that settle; on level ground it is the exact geostatic state.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..platform.memo import Memo, digest

__all__ = ["K0", "GravityLoading", "geostatic_stress", "jaky_k0", "vertical_stress"]

#: samples per column of the weight integral (midpoint rule between the top and the
#: lowest particle); the relative error of a layer's sigma_v is below 1 / SAMPLES
SAMPLES = 20000


@dataclass(frozen=True)
class K0:
    """The K0 procedure as a scene's initial stress: ``k0`` one ratio sigma_h / sigma_v for
    every body, None for each material's own (:func:`jaky_k0`)."""

    k0: float | None = None

    def __post_init__(self):
        if self.k0 is not None:
            try:
                k = float(self.k0)
            except (TypeError, ValueError):
                raise ValueError(f"K0: k0 must be a number or None, got {self.k0!r}") from None
            if not (0.0 < k <= 1.0):
                raise ValueError(f"K0: k0 must lie in (0, 1] (sigma_h / sigma_v of ground at "
                                 f"rest, normally consolidated), got {self.k0!r}")
            object.__setattr__(self, "k0", k)


@dataclass(frozen=True)
class GravityLoading:
    """Gravity loading as a scene's initial stress (run by :func:`timpm.simulation.loading.gravity_loading`,
    which a Solver calls for a world that asks for it): ``damping`` the local damping factor
    of the loading run, ``t_max`` its longest time (None: 40 times the time a P-wave takes
    across the ground's height), ``tolerance`` the kinetic energy at rest per unit of the
    weight times the height."""

    damping: float = 0.6
    t_max: float | None = None
    tolerance: float = 1e-7

    def __post_init__(self):
        if not (isinstance(self.damping, (int, float)) and 0.0 < self.damping < 1.0):
            raise ValueError(f"gravity loading: damping must lie in (0, 1), got {self.damping!r}")
        if self.t_max is not None and not (isinstance(self.t_max, (int, float))
                                           and 0.0 < self.t_max < math.inf):
            raise ValueError(f"gravity loading: t_max must be a positive time, got "
                             f"{self.t_max!r}")
        if not (isinstance(self.tolerance, (int, float)) and 0.0 < self.tolerance < 1.0):
            raise ValueError(f"gravity loading: tolerance must lie in (0, 1), got "
                             f"{self.tolerance!r}")


def jaky_k0(material) -> float:
    """Jaky's K0 = 1 - sin(phi) of a frictional material; nu / (1 - nu) (the lateral
    stress of a confined elastic layer) for one without a friction angle."""
    phi = getattr(material, "friction_angle", None)
    if phi:
        return 1.0 - math.sin(math.radians(phi))
    nu = getattr(material, "nu", None)
    if nu is None:
        raise ValueError(f"the K0 procedure needs a solid: {material.name} has no friction "
                         "angle and no Poisson's ratio")
    return nu / (1.0 - nu)


#: the last vertical stresses computed, kept for a World built again from the same
#: particles and bodies (a strength-reduction trial's)
_VERTICAL = Memo(kept=4)


def vertical_stress(positions, bodies, g, top, level=None):
    """sigma_v (> 0) at each position (n, 2 or 3): g times the mass per area above it
    through the ``bodies`` (shape with ``contains``, density, and optionally the density
    of the water in its pores), up to ``top`` or to the gap above it (a body above a gap
    rests on nothing below it: its weight is not carried across).  Every body that holds a
    point adds its density there, as the World places them: bodies that overlap
    (``allow_overlap``) each fill the common region with their own particles, so a lens
    inside a layer weighs the layer's density plus its own.  Below a still-water ``level``
    (or a water table, a function of x: ``level(x)``) a saturated body weighs its buoyant
    density rho - rho_w: sigma_v is then the effective stress (the free water above the
    ground adds to the pore pressure, not to it)."""
    x = np.asarray(positions, dtype=np.float64)
    key = (digest(x), tuple(tuple(b) for b in bodies), float(g), float(top), level)
    return _VERTICAL.get(key, lambda: _vertical_stress(x, bodies, g, top, level))


def _vertical_stress(x, bodies, g, top, level):
    n, dim = x.shape
    out = np.zeros(n)
    # points sharing a column (x, z) share one integral
    columns = np.delete(x, 1, axis=1)
    keys, where = np.unique(columns, axis=0, return_inverse=True)
    where = where.reshape(-1)
    order = np.argsort(where, kind="stable")  # column c's points: order[starts[c]:starts[c + 1]]
    starts = np.searchsorted(where[order], np.arange(len(keys) + 1))
    bottom = float(x[:, 1].min())
    ds = (top - bottom) / SAMPLES
    s = top - (np.arange(SAMPLES) + 0.5) * ds  # midpoints, top down
    depth_edges = top - np.arange(SAMPLES + 1) * ds
    pts = np.empty((SAMPLES, dim))
    pts[:, 1] = s
    for c, key in enumerate(keys):
        pts[:, [0] + list(range(2, dim))] = key
        rho = np.zeros(SAMPLES)
        free = np.ones(SAMPLES, dtype=bool)
        table = level(float(key[0])) if callable(level) else level  # a water table y_w(x)
        table = None if table is None else float(table)
        submerged = (s < table) if table is not None else np.zeros(SAMPLES, dtype=bool)
        for shape, density, *water in bodies:
            inside = shape.contains(pts)
            rho[inside] += density
            if water and water[0] > 0.0:
                rho[inside & submerged] -= water[0]
            free &= ~inside
        # sigma_v at depth: the weight of the samples above, a linear interpolation between
        # the sample edges (the integral is exact for piecewise constant rho between them);
        # a gap (a sample in no body) carries nothing: the weight restarts below it
        weight = np.cumsum(rho) * ds * g
        weight -= np.maximum.accumulate(np.where(free, weight, 0.0))
        edges = np.concatenate([[0.0], weight])
        rows = order[starts[c]:starts[c + 1]]
        out[rows] = np.interp(x[rows, 1], depth_edges[::-1], edges[::-1])
    return out


def geostatic_stress(positions, bodies, g, top, k0, level=None):
    """Cauchy stresses (n, 3, 3) of ground at rest: sigma_yy = -sigma_v, sigma_xx = sigma_zz
    = -k0 sigma_v (``k0`` one value or one per position); effective stresses under a water
    ``level`` (:func:`vertical_stress`)."""
    sv = vertical_stress(positions, bodies, g, top, level)
    k0 = np.broadcast_to(np.asarray(k0, dtype=np.float64), sv.shape)
    out = np.zeros((len(sv), 3, 3))
    out[:, 1, 1] = -sv
    out[:, 0, 0] = out[:, 2, 2] = -k0 * sv
    return out
