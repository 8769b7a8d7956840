"""The physics of Taichi's ``mpm88`` example as a timpm World.

:func:`mpm88_world` builds it: quadratic B-splines, the MLS-MPM transfer,
:class:`timpm.materials.JFluid` (mpm88's fluid), walls where mpm88 clamps the grid
velocity, the same particles, masses, grid, gravity and time step (``MPM88``).  The
throughput benchmark (``benchmarks/throughput.py``) runs it beside Taichi's own example.
"""
import numpy as np

from ..materials import JFluid
from ..model.world import Body, Points, World

__all__ = ["MPM88", "mpm88_world"]

#: parameters of Taichi's examples/simulation/mpm88.py
MPM88 = dict(n_grid=128, dt=2e-4, p_rho=1.0, gravity=9.8, bound=3, E=400.0)


def mpm88_world(x0, velocity=(0.0, -1.0)):
    """The World that runs mpm88's physics from positions ``x0`` (mpm88's unit square).

    mpm88 clamps the velocity of nodes i < 3 and i > n_grid - 3; timpm's walls hold the
    nodes at and beyond the domain's sides, so the domain is [2 dx, 126 dx]^2 and the
    positions shift by -2 dx (``shift``, returned with the world).
    """
    n_grid, bound = MPM88["n_grid"], MPM88["bound"]
    dx = 1.0 / n_grid
    lo, hi = bound - 1, n_grid - bound + 1  # first and last clamped node inward
    shift = lo * dx
    fluid = JFluid(bulk_modulus=MPM88["E"], density=MPM88["p_rho"])
    body = Body(Points(np.asarray(x0, dtype=np.float64) - shift, (0.5 * dx) ** 2), fluid,
                velocity=velocity)
    world = World(domain=((hi - lo) * dx,) * 2, cells=hi - lo, bodies=[body],
                  basis="uniform-bspline2", transfer="mls-mpm", gravity=(0.0, -MPM88["gravity"]),
                  walls="slip", dt=MPM88["dt"], name="mpm88")
    return world, shift
