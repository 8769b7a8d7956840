"""The study's 1D law."""
import math

import taichi as ti

from ..checks import positive
from .base import Material

__all__ = ["Hypoelastic1D"]


class Hypoelastic1D(Material):
    """The study's 1D law (2.2.4): sigma += (E - sigma) d_eps (``study``), or sigma += E d_eps.

    A :class:`timpm.scene.Scene` makes it from its :class:`timpm.scene.Material`; a 1D
    :class:`timpm.world.World` takes it as a body's material.  The density acts through
    the particle masses."""

    name = "hypoelastic-1d"
    needs = frozenset({"eps"})
    CONSTANTS = ("E", "density")
    dims = (1,)

    def __init__(self, E, density, study: bool = True):
        super().__init__(density)
        self.E, self.study = positive(f"{self.name}: Young's modulus E", E), bool(study)
        self.wave_speed = math.sqrt(self.E / self.density)

    def parameters(self) -> dict:
        return {"E": self.E, "density": self.density, "study": self.study}

    def flags(self) -> tuple:
        return (self.study,)

    def set_flags(self, flags):
        (self.study,) = flags

    def constants(self, dt: float) -> dict:
        return {"E": self.E, "density": self.density}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        deps = 0.5 * (grad_du + grad_du.transpose())
        sig_new = sigma_old + self.c.E() * deps
        if ti.static(self.study):
            sig_new = sigma_old + (self.c.E() - sigma_old) * deps
        s.accumulate(s.eps[p], deps)
        return sig_new
