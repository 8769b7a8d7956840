"""MUSL with a PIC share b of the particle velocity update (``pic_fraction``):

    v_p = (1 - b) (v_p + dt sum_i phi_i a_i) + b sum_i phi_i v_i^L,

v_i^L = P_i / m_i + dt a_i the grid velocity after the update.  b = 0 is the study's FLIP
update; b > 0 damps the particles' velocity noise that FLIP keeps forever (the oedometer at
rest, issue 15), at the price of some dissipation of the resolved motion.  The MUSL step
with two of its functions changed: the grid phase stores v_i^L, the G2P velocity blends.
"""
import taichi as ti

from ..platform.declare import Field, Param
from .musl import MUSL

__all__ = ["PICBlend"]


class PICBlend(MUSL):
    """See the module."""

    #: the PIC share b (``values.pic_fraction()``)
    PARAMS = {"pic_fraction": Param(0.0, "", "PIC share b of the velocity update (0: FLIP, "
                                    "the study's; 1: PIC)", low=0.0, high=1.0)}

    @classmethod
    def applies(cls, features):
        return features.transfer == "musl" and features.pic

    @classmethod
    def check(cls, transfer, dim, basis, mass, projection, damping, params):
        if params["pic_fraction"] and (mass != "lumped" or projection != "standard"):
            raise ValueError(f"pic_fraction blends PIC into the musl transfer's FLIP update "
                             f"with the lumped mass and the standard projection, not "
                             f"{transfer} with {mass} mass and the {projection} projection")

    def __init__(self, features, ops):
        super().__init__(features, ops)
        self.scatters_momentum = True  # the grid phase reads P_i / m_i

    @staticmethod
    def grid_fields(features):
        return {**MUSL.grid_fields(features),
                "gv": Field("vector", doc="v_i^L = P_i / m_i + dt a_i, the updated velocity")}

    @ti.func
    def after_acceleration(self, grid: ti.template(), values: ti.template(), I):
        # v_i^L = P_i / m_i + dt a_i (a wall's a makes it the wall's velocity; zero at
        # Dirichlet and empty nodes)
        v_new = (self.boundary.lumped_solve(I, grid.node_momentum[I])
                 + values.dt() * grid.node_acceleration[I])
        if ti.static(self.f.has_prescribed):
            if self.boundary.is_fixed(I):
                v_new = self.boundary.prescribed_velocity(I, True)
        grid.node_new_velocity[I] = v_new

    @ti.func
    def new_velocity(self, grid: ti.template(), values: ti.template(), base, w, dw, flip):
        # v_p = (1 - b) v_p^FLIP + b sum_i phi_i v_i^L
        pic = self.stencil.interpolate(grid.node_new_velocity, base, w, dw)
        b = values.pic_fraction()
        return (1.0 - b) * flip + b * pic
