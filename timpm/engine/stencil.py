"""The stencil of a particle: its nodes, the basis weights and gradients (any dimension).

Mixed into :class:`~timpm.engine.program.Program`.  Reads ``x`` and the run-time grid
values (``self.p``); the basis (``self.basis``) is a compile-time class whose ``stencil``
``ti.func`` gives the 1D weights, combined here as tensor products.

The phases loop over a particle's stencil nodes with a run-time loop,
``for offset in ti.grouped(ti.ndrange(*self.stencil_shape))``, not an unrolled one
(``ti.static``): Taichi's IR passes cost about the square of a kernel's statement count
(each replaced statement rescans the kernel), and an unrolled 27-node 3D stencil made the
cube scene's step compile for 62 s against 5 s rolled.  LLVM unrolls the constant-count
loops again, so the steps run as fast (``benchmarks/engine_ab.py`` against the
unrolled engine, docs/performance.md).
"""
import taichi as ti

__all__ = ["StencilOps"]


class StencilOps:
    """See the module."""

    @ti.func
    def _stencil(self, p):
        """Node base, weights and gradients of particle p, its coordinate in element units,
        and whether p is on the grid."""
        xi = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            xi[k] = (self.x[p][k] - self.p.origin()[k]) * self.p.inv_h()
        base, w, dw, inside = self._stencil_at(xi)
        return base, w, dw, xi, inside

    @ti.func
    def _stencil_at(self, xi):
        """Node base, weights and gradients at a point ``xi`` (element units), and whether
        it is on the grid."""
        base = ti.Vector.zero(ti.i32, self.dim)
        w = ti.Matrix.zero(float, self.basis.support, self.dim)
        dw = ti.Matrix.zero(float, self.basis.support, self.dim)
        inside = 1
        for k in ti.static(range(self.dim)):
            # NaN fails both comparisons, so it is caught here too
            if not (xi[k] >= 0.0 and xi[k] <= self.p.elements()[k]):
                inside = 0
            b, wk, dwk = self.basis.stencil(xi[k], self.p.elements()[k])
            base[k] = b
            if b < 0 or b + self.basis.support > self.p.nodes()[k]:
                inside = 0
            for a in ti.static(range(self.basis.support)):
                w[a, k] = wk[a]
                dw[a, k] = dwk[a] * self.p.inv_h()
        return base, w, dw, inside

    @ti.func
    def _weight(self, w, dw, offset):
        """Tensor-product value and gradient of the basis function at stencil ``offset``."""
        phi = 1.0
        grad = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            phi *= w[offset[k], k]
        for j in ti.static(range(self.dim)):
            g = 1.0
            for k in ti.static(range(self.dim)):
                if ti.static(j == k):
                    g *= dw[offset[k], k]
                else:
                    g *= w[offset[k], k]
            grad[j] = g
        return phi, grad

    @ti.func
    def _from_first_node(self, xi, base):
        """x_p - x of the stencil's first node, so that x_i - x_p = h o - this for the node
        at stencil offset o (the factored affine terms of P2G and G2P)."""
        return (xi - ti.cast(base, float) + self.node_offset) * self.p.h()

    @ti.func
    def _times_offset(self, A, offset):
        """A o for the stencil offset o."""
        return A @ ti.cast(offset, float)

    @ti.func
    def _outer_offset(self, u, offset):
        """u o^T for the stencil offset o."""
        return u.outer_product(ti.cast(offset, float))

    @ti.func
    def _element(self, xi):
        """Element of a point at ``xi`` (element units), clamped to the grid."""
        e = ti.Vector.zero(ti.i32, self.dim)
        for k in ti.static(range(self.dim)):
            e[k] = ti.min(ti.max(ti.floor(xi[k], ti.i32), 0), self.p.elements()[k] - 1)
        return e
