"""MUSL with a PIC share b of the particle velocity update (``pic_fraction``):

    v_p = (1 - b) (v_p + dt sum_i phi_i a_i) + b sum_i phi_i v_i^L,

v_i^L = P_i / m_i + dt a_i the grid velocity after the update.  b = 0 is the study's FLIP
update; b > 0 damps the particles' velocity noise that FLIP keeps forever (the oedometer at
rest, issue 15), at the price of some dissipation of the resolved motion.  The MUSL step
with two of its functions changed: the grid phase stores v_i^L, the G2P velocity blends.
"""
import taichi as ti

from .musl import MUSL

__all__ = ["PICBlend"]


@ti.data_oriented
class PICBlend(MUSL):
    """See the module."""

    #: the run-time value it reads (``Program.values.pic_fraction()``, ``Model.pic_fraction``)
    PARAMS = {"pic_fraction": "real"}

    @staticmethod
    def applies(features):
        return features.transfer == "musl" and features.pic

    def __init__(self, features):
        super().__init__(features)
        self.scatters_momentum = True  # the grid phase reads P_i / m_i

    @staticmethod
    def grid_fields(dim, real):
        """The grid velocity after the update, v_i^L (node_new_velocity)."""
        return {"gv": ti.Vector.field(dim, real)}

    @ti.func
    def after_acceleration(self, prog: ti.template(), grid: ti.template(),
                           values: ti.template(), I):
        # v_i^L = P_i / m_i + dt a_i (a wall's a makes it the wall's velocity; zero at
        # Dirichlet and empty nodes)
        v_new = (prog.lumped_solve(I, grid.node_momentum[I])
                 + values.dt() * grid.node_acceleration[I])
        if ti.static(prog.prescribed):
            if prog.is_fixed(I):
                v_new = prog.prescribed_velocity(I, True)
        grid.node_new_velocity[I] = v_new

    @ti.func
    def new_velocity(self, prog: ti.template(), grid: ti.template(), values: ti.template(),
                     base, w, dw, flip):
        # v_p = (1 - b) v_p^FLIP + b sum_i phi_i v_i^L
        pic = prog.interpolate(grid.node_new_velocity, base, w, dw)
        b = values.pic_fraction()
        return (1.0 - b) * flip + b * pic
