"""The active window: the grid's node loops only over the box of nodes the particles reach.

The grid is dense over the whole domain, but a landslide's run-out zone and the air above
a column are empty, and every node loop of a step (the clear, the mass solve, a scheme's
node phases, the private copies' merge) visited them.  With the window (``grid="window"``,
compiled in only where a feature set asks: ``FeatureSet.grid_window``) each step starts
with one phase:

1. the particles' extent in element units, xi_min and xi_max per axis (each block of the
   private scatter's split on its thread, without atomics, then the blocks combined);
2. the stencil nodes of those extremes: the particle window P_n = [b(xi_min), b(xi_max) +
   support) per axis (b, the basis's first stencil node, is monotone in xi, so every
   particle's stencil lies inside);
3. the step's node loops run over U_n, the box around P_n and the last step's P_{n-1}.

Why U_n and not P_n: P_{n-1} is where the last step wrote; clearing U_n zeroes what it
left, and a node outside U_n was zeroed the last time it was inside one (a program loaded
from the host starts with a zeroed grid and an empty P_{n-1}).  Every stencil node of
this step lies in P_n, so the particles see exactly the dense grid's values: the results
are those of the dense loops bit for bit.  What differs is what no particle reads: an
empty node outside U_n keeps zero, where the dense loops would store a moving wall's or a
prescribed node's velocity.  The memory stays dense (the fields are not sparse): the
window saves the work.
"""
import taichi as ti

from .expressions import at, expression

__all__ = ["ActiveWindow", "window_fields"]

#: the window's integer entries per axis k of dim: P_{n-1} [lo, hi), then U_n [lo, hi)
PREV_LO, PREV_HI, LO, HI = range(4)


def window_fields(real):
    """The window's scratch fields, to be placed 4 dim and 2 dim times the blocks long: its
    boxes (integers) and the particles' extent per block (cleared when a state is loaded:
    P_{n-1} empty)."""
    return {"window_box": ti.field(ti.i32), "window_extent": ti.field(real)}


class ActiveWindow:
    """See the module: the feature set, the run-time values and the scratch fields
    ``box`` (4 dim integers) and ``extent`` (2 dim reals)."""

    def __init__(self, features, values, box, extent):
        self.dim, self.basis = features.dim, features.basis
        #: the particles' blocks, one per thread of the private scatter's split
        self.blocks = features.n_copies
        self.support = self.basis.support
        self.values, self.box, self.extent = values, box, extent

    @expression
    def ranges(self):
        """U_n as ``ti.ndrange`` arguments: (lo, hi) per axis."""
        d = self.dim
        return [(at(self.box, LO * d + k), at(self.box, HI * d + k)) for k in range(d)]

    @ti.func
    def find(self, particles: ti.template(), grid: ti.template(), values: ti.template()):
        # the active window (module): xi_min, xi_max over the particles on the grid, per
        # block of the private scatter's split (thread c the particles [c B, (c + 1) B):
        # no atomics, which two threads contending for four values made cost as much as
        # the step), then over the blocks
        d = ti.static(self.dim)
        B = values.scatter_block()
        for q in range(self.blocks * B):
            if q % B == 0:
                c = q // B
                lo = ti.Vector([3.0e38] * d)
                hi = ti.Vector([-3.0e38] * d)
                for p in range(c * B, ti.min((c + 1) * B, values.n_particles())):
                    for k in ti.static(range(d)):
                        xi = (particles.x[p][k] - values.origin()[k]) * values.inv_h()
                        if xi >= 0.0 and xi <= values.elements()[k]:  # (off it: P2G fails)
                            lo[k] = ti.min(lo[k], xi)
                            hi[k] = ti.max(hi[k], xi)
                for k in ti.static(range(d)):
                    self.extent[c * 2 * d + k] = lo[k]
                    self.extent[c * 2 * d + d + k] = hi[k]
        ti.loop_config(serialize=True)  # one thread combines the blocks (no race on 0)
        for c in range(1, self.blocks):
            for k in ti.static(range(d)):
                self.extent[k] = ti.min(self.extent[k], self.extent[c * 2 * d + k])
                self.extent[d + k] = ti.max(self.extent[d + k], self.extent[c * 2 * d + d + k])
        # P_n from the extremes' stencils, U_n = box(P_n, P_{n-1}); P_n kept for the next
        for k in ti.static(range(d)):
            lo, hi = 0, 0
            if self.extent[k] <= self.extent[d + k]:  # some particle on the grid
                b_lo, _, _ = self.basis.stencil(self.extent[k], values.elements()[k])
                b_hi, _, _ = self.basis.stencil(self.extent[d + k], values.elements()[k])
                lo = ti.max(b_lo, 0)
                hi = ti.min(b_hi + self.support, values.nodes()[k])
            prev_lo, prev_hi = self.box[PREV_LO * d + k], self.box[PREV_HI * d + k]
            u_lo, u_hi = lo, hi
            if prev_lo < prev_hi:
                if hi <= lo:
                    u_lo, u_hi = prev_lo, prev_hi
                else:
                    u_lo, u_hi = ti.min(lo, prev_lo), ti.max(hi, prev_hi)
            self.box[LO * d + k] = u_lo
            self.box[HI * d + k] = u_hi
            self.box[PREV_LO * d + k] = lo
            self.box[PREV_HI * d + k] = hi
