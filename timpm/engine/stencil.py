"""The stencil of a particle: its nodes, the basis weights and gradients (any dimension).

The basis (``features.basis``) is a compile-time class whose ``stencil`` ``ti.func`` gives
the 1D weights; this unit combines them as tensor products, reading only the run-time
grid values (origin, 1 / h, elements and nodes per axis).

A phase visits a particle's stencil nodes row by row: a run-time loop over the rows (every
axis but the last: ``rows`` = support^(dim - 1), one in 1D) and the row's nodes unrolled::

    for r in range(self.stencil.rows):
        for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
            ...  # node base + offset, basis value phi, gradient grad

(``row``: the row's weight products over those axes once, then per node the same products
in the same order as ``node_weight``, so the same bits; 3D steps 3 % faster than the
products per node, docs/performance.md).  Taichi's IR passes cost about the square of a
kernel's statement count (each replaced statement rescans the kernel): the 3D cube scene's
step, 27 nodes unrolled, compiled cold for 62 s, 2.2 s by rows.  The unrolled row keeps the
weights of the last axis in registers and the column adds of ``times_offset``; 1D stencils
are unrolled whole (docs/performance.md, "Time to the first step").
"""
import taichi as ti

from .expressions import at, expression, variable

__all__ = ["Stencil"]


class Stencil:
    """See the module: ``features`` (the dimension and basis) and the run-time ``values``."""

    def __init__(self, features, values):
        self.dim, self.basis, self.values = features.dim, features.basis, values
        self.support = self.basis.support
        #: the rows of a stencil: every axis but the last
        self.rows = self.support ** (self.dim - 1)
        #: padding nodes before x = 0 (the uniform B-splines)
        self.node_offset = features.node_offset
        #: x periodic: the node index along x modulo the elements (``node``)
        self.periodic = getattr(features, "periodic", False)

    @ti.func
    def of(self, x):
        """Node base, weights and gradients of a particle at ``x``, its coordinate in
        element units, and whether it is on the grid."""
        xi = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            xi[k] = (x[k] - self.values.origin()[k]) * self.values.inv_h()
        base, w, dw, inside = self.at(xi)
        return base, w, dw, xi, inside

    @ti.func
    def at(self, xi):
        """Node base, weights and gradients at a point ``xi`` (element units), and whether
        it is on the grid."""
        base = ti.Vector.zero(ti.i32, self.dim)
        w = ti.Matrix.zero(float, self.support, self.dim)
        dw = ti.Matrix.zero(float, self.support, self.dim)
        inside = 1
        for k in ti.static(range(self.dim)):
            # NaN fails both comparisons, so it is caught here too
            if not (xi[k] >= 0.0 and xi[k] <= self.values.elements()[k]):
                inside = 0
            b, wk, dwk = self.basis.stencil(xi[k], self.values.elements()[k])
            base[k] = b
            if ti.static(self.periodic and k == 0):
                pass  # the stencil wraps round (``node``): on the grid where xi is
            elif b < 0 or b + self.support > self.values.nodes()[k]:
                inside = 0
            for a in ti.static(range(self.support)):
                w[a, k] = wk[a]
                dw[a, k] = dwk[a] * self.values.inv_h()
        return base, w, dw, inside

    @ti.func
    def node(self, base, offset):
        """The grid index of the stencil node at ``offset``: base + offset, along a
        periodic x modulo the elements (node n_x is node 0)."""
        I = base + offset
        if ti.static(self.periodic):
            if I[0] >= self.values.elements()[0]:
                I[0] -= self.values.elements()[0]
        return I

    @ti.func
    def node_weight(self, w, dw, offset):
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
    def from_first_node(self, xi, base):
        """x_p - x of the stencil's first node, so that x_i - x_p = h o - this for the node
        at stencil offset o (the factored affine terms of P2G and G2P)."""
        return (xi - ti.cast(base, float) + self.node_offset) * self.values.h()

    @expression
    def _row_offsets(self, r):
        """(o_0, o_1) of stencil row r: the offsets along every axis but the last (the
        rows run in C order; unused axes zero); expressions, not variables."""
        if self.dim == 3:
            return r // self.support, r % self.support
        if self.dim == 2:
            return 0, r
        return 0, 0

    @expression
    def _offset_of(self, r, a):
        """The stencil offset of node a (a Python integer) of row r."""
        o0, o1 = self._row_offsets(r)
        return ti.Vector([o0, o1, a][3 - self.dim:])

    @expression
    def _row_products(self, w, dw, r):
        """The products of stencil row r over every axis but the last: (w_0 w_1, dw_0 w_1,
        w_0 dw_1) in 3D, (w_0, dw_0, 0) in 2D, (1, 0, 0) in 1D."""
        o0, o1 = self._row_offsets(r)
        if self.dim == 3:
            return ti.Vector([at(w, o0, 0) * at(w, o1, 1), at(dw, o0, 0) * at(w, o1, 1),
                              at(w, o0, 0) * at(dw, o1, 1)])
        if self.dim == 2:
            return ti.Vector([at(w, o1, 0), at(dw, o1, 0), 0.0])
        return ti.Vector([1.0, 0.0, 0.0])

    @expression
    def _row_node(self, w, dw, r, row, a):
        """Node a of stencil row r from the row's products: its offset, basis value and
        gradient, the same numbers as ``node_weight``."""
        last = self.dim - 1
        w_a, dw_a = at(w, a, last), at(dw, a, last)
        phi = at(row, 0) * w_a
        if self.dim == 3:
            grad = ti.Vector([at(row, 1) * w_a, at(row, 2) * w_a, at(row, 0) * dw_a])
        elif self.dim == 2:
            grad = ti.Vector([at(row, 1) * w_a, at(row, 0) * dw_a])
        else:
            grad = ti.Vector([at(row, 0) * dw_a])
        return self._offset_of(r, a), phi, grad

    @expression
    def row(self, w, dw, r):
        """The nodes of stencil row r, for a ``ti.static`` loop in the loop over the rows:
        per node a (a Python integer) its offset o, basis value phi and gradient grad.  The
        row's products are one variable, made here; each node's offset, value and gradient
        one each, made as the static loop reaches the node (a lazy ``map``: the variables
        stand where an assignment at the top of the node's body would make them)."""
        products = variable(self._row_products(w, dw, r))

        def node(a):
            offset, phi, grad = self._row_node(w, dw, r, products, a)
            return a, variable(offset), variable(phi), variable(grad)

        return map(node, range(self.support))

    @ti.func
    def interpolate(self, node_field: ti.template(), base, w, dw):
        """A vector grid field at a particle: sum_i phi_i f_i over its stencil."""
        value = ti.Vector.zero(float, self.dim)
        for r in range(self.rows):
            for a, offset, phi, grad in ti.static(self.row(w, dw, r)):
                value += phi * node_field[self.node(base, offset)]
        return value

    @ti.func
    def times_offset(self, A, r, a: ti.template()):
        """A o for the offset o of node a of stencil row r: the row's axes as products,
        the last axis (unrolled) as column adds."""
        o0, o1 = self._row_offsets(r)
        out = ti.Vector.zero(float, self.dim)
        if ti.static(self.dim > 2):
            out += A[:, 0] * o0
        if ti.static(self.dim > 1):
            out += A[:, self.dim - 2] * o1
        if ti.static(a == 1):
            out += A[:, self.dim - 1]
        elif ti.static(a > 1):
            out += a * A[:, self.dim - 1]
        return out

    @ti.func
    def outer_offset(self, u, r, a: ti.template()):
        """u o^T for the offset o of node a of stencil row r."""
        o0, o1 = self._row_offsets(r)
        out = ti.Matrix.zero(float, self.dim, self.dim)
        for j in ti.static(range(self.dim)):
            if ti.static(self.dim > 2):
                out[j, 0] = u[j] * o0
            if ti.static(self.dim > 1):
                out[j, self.dim - 2] = u[j] * o1
            if ti.static(a == 1):
                out[j, self.dim - 1] = u[j]
            elif ti.static(a > 1):
                out[j, self.dim - 1] = a * u[j]
        return out

    @ti.func
    def element_of(self, xi):
        """Element of a point at ``xi`` (element units), clamped to the grid."""
        e = ti.Vector.zero(ti.i32, self.dim)
        for k in ti.static(range(self.dim)):
            e[k] = ti.min(ti.max(ti.floor(xi[k], ti.i32), 0), self.values.elements()[k] - 1)
        return e
