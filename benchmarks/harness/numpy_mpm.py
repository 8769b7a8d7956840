"""Vectorised NumPy implementations of two timpm steps, the baselines of the throughput
benchmark (``benchmarks/throughput.py``) and independent checks of the Taichi kernels.

* :func:`mpm88_step` -- the physics of Taichi's ``mpm88`` example (Hu et al. 2018): 2D,
  quadratic B-splines, MLS-MPM affine transfer, a fluid whose J advances as
  J (1 + dt tr C), walls ``bound`` cells in, gravity.  The scatter uses ``np.bincount``, the
  fastest scatter-add NumPy offers (``np.add.at`` is several times slower).
* :class:`Numpy1D` -- the study's 1D algorithm (2.2.4: MUSL, Euler-Cromer, lumped mass,
  linear basis, Dirichlet nodes, the study's stress update), written as a NumPy user would.
"""
import numpy as np

from timpm.scenarios.mpm88 import MPM88

__all__ = ["MPM88", "mpm88_initial", "mpm88_step", "mpm88_run", "Numpy1D"]


def mpm88_initial(n_particles, seed=0):
    """mpm88's initial state: a square [0.2, 0.6]^2 of random particles falling at 1 m/s."""
    rng = np.random.default_rng(seed)
    x = rng.random((n_particles, 2)) * 0.4 + 0.2
    v = np.tile([0.0, -1.0], (n_particles, 1))
    return x, v, np.zeros((n_particles, 2, 2)), np.ones(n_particles)


def _stencil(w, fx, base, dx, n_grid):
    """The 3 x 3 quadratic stencil of every particle, node by node: weight, x_i - x_p and
    the flattened node index.  Recomputed for P2G and G2P: holding all nine is ~20% slower
    (memory traffic)."""
    for i in range(3):
        for j in range(3):
            yield (w[i][:, 0] * w[j][:, 1], (i - fx[:, 0]) * dx, (j - fx[:, 1]) * dx,
                   (base[:, 0] + i) * n_grid + base[:, 1] + j)


def mpm88_step(x, v, C, J, n_grid=MPM88["n_grid"], dt=MPM88["dt"], p_rho=MPM88["p_rho"],
               gravity=MPM88["gravity"], bound=MPM88["bound"], E=MPM88["E"]):
    """One mpm88 substep on float64 arrays, in place (x, v, C, J)."""
    dx = 1.0 / n_grid
    inv_dx = float(n_grid)
    p_vol = (dx * 0.5) ** 2
    p_mass = p_vol * p_rho
    n_nodes = n_grid * n_grid
    Xp = x * inv_dx
    base = (Xp - 0.5).astype(np.int64)
    fx = Xp - base
    w = (0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2)
    stress = -dt * 4.0 * E * p_vol * (J - 1.0) * inv_dx ** 2
    affine = p_mass * C
    affine[:, 0, 0] += stress
    affine[:, 1, 1] += stress
    mv = p_mass * v
    # P2G: nine bincounts per component over the flattened node index
    gm = np.zeros(n_nodes)
    gvx = np.zeros(n_nodes)
    gvy = np.zeros(n_nodes)
    for weight, dpx, dpy, node in _stencil(w, fx, base, dx, n_grid):
        mom_x = weight * (mv[:, 0] + affine[:, 0, 0] * dpx + affine[:, 0, 1] * dpy)
        mom_y = weight * (mv[:, 1] + affine[:, 1, 0] * dpx + affine[:, 1, 1] * dpy)
        gm += np.bincount(node, weight * p_mass, n_nodes)
        gvx += np.bincount(node, mom_x, n_nodes)
        gvy += np.bincount(node, mom_y, n_nodes)
    # grid: momentum to velocity, gravity, separating walls
    has = gm > 0
    gvx[has] /= gm[has]
    gvy[has] /= gm[has]
    gvy -= dt * gravity
    gvx = gvx.reshape(n_grid, n_grid)
    gvy = gvy.reshape(n_grid, n_grid)
    idx = np.arange(n_grid)
    lo, hi = idx < bound, idx > n_grid - bound
    gvx[lo, :] = np.maximum(gvx[lo, :], 0.0)
    gvx[hi, :] = np.minimum(gvx[hi, :], 0.0)
    gvy[:, lo] = np.maximum(gvy[:, lo], 0.0)
    gvy[:, hi] = np.minimum(gvy[:, hi], 0.0)
    gvx = gvx.ravel()
    gvy = gvy.ravel()
    # G2P: gather velocity and the affine matrix C = 4 / dx^2 sum w v_i dpos^T
    new_v = np.zeros_like(v)
    new_C = np.zeros_like(C)
    for weight, dpx, dpy, node in _stencil(w, fx, base, dx, n_grid):
        vx, vy = gvx[node], gvy[node]
        new_v[:, 0] += weight * vx
        new_v[:, 1] += weight * vy
        k = 4.0 * inv_dx ** 2 * weight
        new_C[:, 0, 0] += k * vx * dpx
        new_C[:, 0, 1] += k * vx * dpy
        new_C[:, 1, 0] += k * vy * dpx
        new_C[:, 1, 1] += k * vy * dpy
    v[:] = new_v
    x += dt * v
    J *= 1.0 + dt * (new_C[:, 0, 0] + new_C[:, 1, 1])
    C[:] = new_C


def mpm88_run(x, v, C, J, n_steps, **params):
    """``n_steps`` mpm88 substeps on copies of the state; returns the new (x, v, C, J)."""
    x, v, C, J = (np.array(a, dtype=np.float64) for a in (x, v, C, J))
    for _ in range(n_steps):
        mpm88_step(x, v, C, J, **params)
    return x, v, C, J


class Numpy1D:
    """The study's 1D algorithm (2.2.4) for a :class:`timpm.Scene` with the linear basis and
    lumped mass, vectorised with ``np.bincount``: P2G of mass and force, a = F / m, G2P of
    the velocity, P2G of the momentum, v_i = P_i / m_i, G2P of the strain increment, the
    study's stress update sigma += (E - sigma) d_eps (or E d_eps) and V *= 1 + d_eps."""

    def __init__(self, scene):
        if scene.basis.name != "linear" or scene.mass != "lumped":
            raise ValueError("Numpy1D implements the linear basis with the lumped mass")
        if scene.traction is not None or scene.damping or scene.projection != "standard":
            raise ValueError("Numpy1D has no tractions, damping or MLS projection")
        self.h = scene.grid.h
        self.origin = scene.grid.origin
        self.n_nodes = scene.grid.n_elements + 1
        self.fixed = np.asarray(scene.fixed_nodes, dtype=np.int64)
        self.E = scene.material.E
        self.study = scene.material.stress_update == "study"
        self.g = float(scene.gravity)
        self.dt = scene.dt
        self.x = scene.positions.astype(np.float64).copy()
        self.v = scene.velocity.astype(np.float64).copy()
        self.vol = scene.volume.astype(np.float64).copy()
        self.m = scene.mass_per_particle.astype(np.float64).copy()
        self.sigma = np.zeros_like(self.x)
        self.u = np.zeros_like(self.x)

    def step(self):
        h, nn, dt = self.h, self.n_nodes, self.dt
        xi = (self.x - self.origin) / h
        e = np.clip(np.floor(xi).astype(np.int64), 0, nn - 2)
        r = xi - e
        n0, n1 = 1.0 - r, r  # linear shape functions and their gradients -+1/h
        mass = np.bincount(e, self.m * n0, nn) + np.bincount(e + 1, self.m * n1, nn)
        sv = self.sigma * self.vol / h
        fg = self.m * self.g
        force = (np.bincount(e, fg * n0 + sv, nn) + np.bincount(e + 1, fg * n1 - sv, nn))
        live = mass > 1e-14 * self.m.mean()
        acc = np.zeros(nn)
        acc[live] = force[live] / mass[live]
        acc[self.fixed] = 0.0
        self.v += dt * (n0 * acc[e] + n1 * acc[e + 1])
        mom = np.bincount(e, self.m * n0 * self.v, nn) + np.bincount(e + 1, self.m * n1 * self.v, nn)
        vel = np.zeros(nn)
        vel[live] = mom[live] / mass[live]
        vel[self.fixed] = 0.0
        du = dt * (n0 * vel[e] + n1 * vel[e + 1])
        deps = dt * (vel[e + 1] - vel[e]) / h
        self.u += du
        self.x += du
        self.sigma += ((self.E - self.sigma) if self.study else self.E) * deps
        self.vol *= 1.0 + deps

    def run(self, n_steps):
        for _ in range(n_steps):
            self.step()
        return self
