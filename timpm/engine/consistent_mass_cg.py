"""The consistent mass matrix in 2D and 3D: matrix-free preconditioned conjugate gradients.

For ``mass="consistent"`` on a 2D or 3D grid.  ``M_ij = sum_p m_p phi_i(x_p) phi_j(x_p)``
is never assembled: ``M v`` is a gather and a scatter over the particles, ``(M v)_i = sum_p
phi_i(x_p) m_p sum_j phi_j(x_p) v_j``, with each particle's node base and weights kept from
the step's P2G (``cg_base``, ``cg_phi``).  ``M x = b`` is solved per component on the free
degrees of freedom (the constraint C zeroes Dirichlet and empty nodes and the components
that roller and sticky walls hold: linear, homogeneous constraints), started from the
lumped solution and preconditioned by the lumped mass (B-splines are non-negative: M is
positive definite and spectrally close to its lumping).  It runs on one thread, so a solve
is the same bit for bit in every mode.
"""
import itertools

import taichi as ti

from ..platform.errors import ErrorCode

__all__ = ["CGMass", "cg_fields", "cg_particle_fields", "CG_MAX_ITERATIONS"]

#: iterations after which a solve that has not converged stops the run
CG_MAX_ITERATIONS = 500


def cg_fields(dim, real):
    """The solver's vectors on the grid: the solution, residual, preconditioned residual,
    direction and the mass times the direction."""
    return {name: ti.Vector.field(dim, real)
            for name in ("cg_x", "cg_r", "cg_z", "cg_d", "cg_q")}


def cg_particle_fields(dim, support, real):
    """Each particle's node base and tensor-product weights at this step's positions."""
    return {"cg_base": ti.Vector.field(dim, ti.i32),
            "cg_phi": ti.Vector.field(support ** dim, real)}


class CGMass:
    """See the module: the feature set, the stencil, the boundary (Dirichlet nodes, walls,
    the lumped solve that preconditions), the failure record, the particles' masses, the
    solver's vectors on the grid and per particle (``scratch``: :func:`cg_fields`,
    :func:`cg_particle_fields`) and the run-time values."""

    def __init__(self, features, stencil, boundary, failures, particles, scratch, values):
        self.f, self.dim, self.support = features, features.dim, features.basis.support
        self.stencil, self.boundary, self.failures = stencil, boundary, failures
        self.particles, self.work, self.values = particles, scratch, values

    @ti.func
    def keep_weights(self, particles: ti.template(), values: ti.template()):
        # the particles' node bases and weights phi_i(x_p) for the mass products of the step
        for p in range(values.n_particles()):
            base, w, dw, xi, inside = self.stencil.of(particles.x[p])
            offsets = ti.static(self._cg_offsets())
            phi = ti.Vector.zero(float, ti.static(len(offsets)))
            if inside:
                for k in ti.static(range(len(offsets))):
                    value, _ = self.stencil.node_weight(w, dw, offsets[k])
                    phi[k] = value
            self.work.cg_base[p] = base
            self.work.cg_phi[p] = phi  # zero off the grid

    def _cg_offsets(self):
        """The stencil's node offsets in the order of ``cg_phi``."""
        return [tuple(o) for o in itertools.product(range(self.support), repeat=self.dim)]

    @ti.func
    def _constrained(self, I, v):
        """C v at node I: zero at Dirichlet and empty nodes, the walls' held components
        zeroed (roller and sticky walls only: the Model refuses the others)."""
        out = ti.Vector.zero(float, self.dim)
        if self.boundary.is_free(I):
            out = self._held_by_walls(I, v)
        return out

    @ti.func
    def _held_by_walls(self, I, v):
        out = v
        if ti.static(self.f.walled):
            out = self.boundary.apply_walls(I, v)
        return out

    @ti.func
    def _precondition(self):
        """z = C M_L^-1 r and the sums r . z per component."""
        rz = ti.Vector.zero(float, self.dim)
        for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
            z = self._held_by_walls(I, self.boundary.lumped_solve(I, self.work.cg_r[I]))
            self.work.cg_z[I] = z
            rz += self.work.cg_r[I] * z
        return rz

    @ti.func
    def solve(self, rhs: ti.template()):
        """rhs <- x with C M C x = C rhs, x = C x (a velocity or an acceleration)."""
        tol = ti.static(1e-12 if self.f.precision == "f64" else 1e-5)
        offsets = ti.static(self._cg_offsets())
        for _ in range(1):  # one thread: the sums in a fixed order
            # x0 = C M_L^-1 b, the first direction d = x0 (its product gives r0 = C b - M x0)
            b2 = ti.Vector.zero(float, self.dim)
            for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                b = self._constrained(I, rhs[I])
                b2 += b * b
                self.work.cg_r[I] = b
                self.work.cg_x[I] = self._held_by_walls(I, self.boundary.lumped_solve(I, rhs[I]))
                self.work.cg_d[I] = self.work.cg_x[I]
            rz = ti.Vector.zero(float, self.dim)
            converged = False
            for it in range(CG_MAX_ITERATIONS + 1):
                # q = C M d: gather s = m_p sum_j phi_j d_j per particle, scatter phi_i s
                for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                    self.work.cg_q[I] = ti.Vector.zero(float, self.dim)
                for p in range(self.values.n_particles()):
                    base, phi = self.work.cg_base[p], self.work.cg_phi[p]
                    s = ti.Vector.zero(float, self.dim)
                    for k in ti.static(range(len(offsets))):
                        s += phi[k] * self.work.cg_d[base + ti.Vector(offsets[k])]
                    s *= self.particles.m[p]
                    for k in ti.static(range(len(offsets))):
                        self.work.cg_q[base + ti.Vector(offsets[k])] += phi[k] * s
                dq = ti.Vector.zero(float, self.dim)
                for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                    self.work.cg_q[I] = self._constrained(I, self.work.cg_q[I])
                    dq += self.work.cg_d[I] * self.work.cg_q[I]
                alpha = ti.Vector.zero(float, self.dim)
                if it == 0:  # r0 = C b - C M x0
                    for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k]
                                                     for k in range(self.dim)])):
                        self.work.cg_r[I] -= self.work.cg_q[I]
                else:  # alpha = r.z / d.q, x += alpha d, r -= alpha q (per component)
                    for k in ti.static(range(self.dim)):
                        if dq[k] > 0.0:
                            alpha[k] = rz[k] / dq[k]
                    for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k]
                                                     for k in range(self.dim)])):
                        self.work.cg_x[I] += alpha * self.work.cg_d[I]
                        self.work.cg_r[I] -= alpha * self.work.cg_q[I]
                r2 = ti.Vector.zero(float, self.dim)
                for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                    r2 += self.work.cg_r[I] * self.work.cg_r[I]
                if (r2 <= tol * tol * b2).all():
                    converged = True
                    break
                # z = C M_L^-1 r, d = z + beta d (d = z at the start)
                rz_new = self._precondition()
                beta = ti.Vector.zero(float, self.dim)
                if it > 0:
                    for k in ti.static(range(self.dim)):
                        if rz[k] > 0.0:
                            beta[k] = rz_new[k] / rz[k]
                rz = rz_new
                for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                    self.work.cg_d[I] = self.work.cg_z[I] + beta * self.work.cg_d[I]
            if not converged:
                self.failures.fail(ErrorCode.MASS_SOLVE, 0)
            for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                rhs[I] = self.work.cg_x[I]
