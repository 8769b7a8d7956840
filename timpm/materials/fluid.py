"""Weakly compressible (Tait) fluid."""

import taichi as ti

from ..platform.declare import Param
from .base import Material

__all__ = ["WeaklyCompressibleFluid"]


class WeaklyCompressibleFluid(Material):
    """Tait fluid: p = K / gamma (J^-gamma - 1), sigma = -p I + 2 mu_visc sym(grad v).

    J = V / V0 comes from the particle volume, so the fluid keeps no extra state.  With
    ``tension=False`` (default) the pressure is clipped at zero: free-surface particles
    do not pull on each other.
    """

    name = "fluid"
    CONSTANTS = ("density", "k_over_gamma", "minus_gamma", "viscosity_over_dt")

    PARAMS = {**Material.PARAMS,
              "bulk_modulus": Param(unit="Pa", doc="bulk modulus", low=0.0, low_open=True),
              "gamma": Param(doc="Tait exponent", low=0.0, low_open=True),
              "viscosity": Param(unit="Pa s", doc="dynamic viscosity", low=0.0),
              "tension": Param(kind="bool", doc="the fluid carries tension")}

    def __init__(self, bulk_modulus, density, gamma=7.0, viscosity=0.0, tension=False):
        super().__init__(density)
        self.bulk_modulus = self.checked("bulk_modulus", bulk_modulus)
        self.gamma = self.checked("gamma", gamma)
        self.viscosity = self.checked("viscosity", viscosity)
        self.tension = self.checked("tension", tension)
        self.wave_speed = self.speed_of("bulk_modulus", self.bulk_modulus)

    def parameters(self) -> dict:
        return {"bulk_modulus": self.bulk_modulus, "density": self.density,
                "gamma": self.gamma, "viscosity": self.viscosity}

    @property
    def free_expansion(self) -> bool:
        """Without tension a particle expands stress-free."""
        return not self.tension

    def flags(self) -> tuple:
        # an integral exponent is compiled in: J^-gamma by multiplications, not pow()
        whole = float(self.gamma) if float(self.gamma).is_integer() else None
        return (self.tension, self.viscosity > 0.0, whole)

    def set_flags(self, flags):
        self.tension, self.viscous, self.whole_gamma = flags
        self.compiled_gamma = self.whole_gamma is not None

    def constants(self, dt: float, h: float) -> dict:
        return {"density": self.density, "k_over_gamma": self.bulk_modulus / self.gamma,
                "minus_gamma": -self.gamma, "viscosity_over_dt": self.viscosity / dt}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        d = ti.static(s.dim)
        eye = ti.Matrix.identity(float, d)
        J = s.vol[p] * self.c.density() / s.m[p]
        power = 0.0
        if ti.static(self.compiled_gamma):
            power = ti.pow(J, -self.whole_gamma)
        else:
            power = ti.pow(J, self.c.minus_gamma())
        pressure = self.c.k_over_gamma() * (power - 1.0)
        if ti.static(not self.tension):
            pressure = ti.max(pressure, 0.0)
        sigma = -pressure * eye
        if ti.static(self.viscous):
            sigma += self.c.viscosity_over_dt() * (grad_du + grad_du.transpose())
        return sigma
