"""The fluid of Taichi's mpm88."""

import taichi as ti

from ..platform.declare import Field, Param
from .base import Material

__all__ = ["JFluid"]


class JFluid(Material):
    """The fluid of Taichi's ``mpm88`` (Hu et al. 2018): J advances by its linearised rate,
    J <- J (1 + tr grad du), and the pressure K (1 - J) acts on the initial volume
    (sigma V = K (J - 1) V0 I).  Cheaper than :class:`WeaklyCompressibleFluid` and
    first-order in the step; here to run mpm88's physics side by side with it.  As in
    mpm88, a particle's volume stays V0 (J holds the volume ratio)."""

    name = "j-fluid"
    initial_volume = True
    free_expansion = True  # no tension: a particle expands stress-free
    CONSTANTS = ("density", "bulk_modulus")

    PARAMS = {**Material.PARAMS,
              "bulk_modulus": Param(unit="Pa", doc="bulk modulus", low=0.0, low_open=True)}

    def __init__(self, bulk_modulus, density):
        super().__init__(density)
        self.bulk_modulus = self.checked("bulk_modulus", bulk_modulus)
        self.wave_speed = self.speed_of("bulk_modulus", self.bulk_modulus)

    @classmethod
    def particle_fields(cls, dim):
        return {"J": Field(initial=1.0, doc="the volume ratio, by its linearised rate")}

    def parameters(self) -> dict:
        return {"bulk_modulus": self.bulk_modulus, "density": self.density}

    def constants(self, dt: float, h: float) -> dict:
        return {"density": self.density, "bulk_modulus": self.bulk_modulus}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        J = s.J[p] * (1.0 + grad_du.trace())
        s.J[p] = J
        scale = 1.0  # V = V0 alone: no division by a volume that a crushed particle drives to 0
        if ti.static(s.update_volume):  # mixed with materials whose volume changes
            scale = self._initial_over_current_volume(s, p)
        return (self.c.bulk_modulus() * (J - 1.0) * scale) * ti.Matrix.identity(float, s.dim)
