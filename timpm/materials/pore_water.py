"""The water in a saturated soil's pores: a property of a body, beside its law.

A :class:`PoreWater` is a value, checked on construction: the soil's porosity n, its
permeability (the hydraulic conductivity k in m/s, or the intrinsic permeability kappa in
m^2 with the water's dynamic viscosity mu: k = kappa rho_w g / mu), the water's density
rho_w and bulk modulus K_w.  The soil's law then acts on the effective stress sigma' and the
total stress is sigma' - p I (compression negative, the pore pressure p positive).  What the
engine makes of it, the scene's analysis (drained, undrained, coupled), is the
:class:`timpm.model.water.Water` of the scene.

The derived numbers the engine reads:

- ``storage_modulus`` K_w / n: the undrained pore pressure rate, dp = -(K_w / n) d eps_v;
- ``drag(g)``: the Darcy drag per unit volume and relative water velocity, n rho_w g / k
  (the momentum the water gives the soil skeleton, Anura3D's single-point two-phase
  formulation); ``g`` the standard gravity the conductivity is measured under.
"""
import math

from ..platform.declare import Param
from ..platform.errors import InputError

__all__ = ["PoreWater", "STANDARD_GRAVITY"]

#: the gravity a hydraulic conductivity is measured under (m/s^2): k = kappa rho_w g / mu
STANDARD_GRAVITY = 9.81


class PoreWater:
    """See the module.  Give ``conductivity`` (k, m/s) or ``permeability`` (kappa, m^2, with
    ``viscosity``), not both; a fully undrained or drained analysis needs neither."""

    name = "pore water"
    PARAMS = {
        "porosity": Param(doc="the pores' share of the soil's volume, n", low=0.0, high=1.0,
                          low_open=True, high_open=True),
        "conductivity": Param(unit="m/s", doc="hydraulic conductivity k (Darcy: q = -k grad h)",
                              low=0.0, low_open=True, optional=True),
        "permeability": Param(unit="m^2", doc="intrinsic permeability kappa = k mu / (rho_w g)",
                              low=0.0, low_open=True, optional=True),
        "viscosity": Param(default=1.0e-3, unit="Pa s", doc="the water's dynamic viscosity",
                           low=0.0, low_open=True),
        "density": Param(default=1000.0, unit="kg/m^3", doc="the water's density rho_w",
                         low=0.0, low_open=True),
        "bulk_modulus": Param(default=2.2e9, unit="Pa", doc="the water's bulk modulus K_w",
                              low=0.0, low_open=True),
    }

    def __init__(self, porosity, conductivity=None, permeability=None, viscosity=1.0e-3,
                 density=1000.0, bulk_modulus=2.2e9):
        check = lambda key, value: self.PARAMS[key].check(self.name, key, value)  # noqa: E731
        self.porosity = check("porosity", porosity)
        self.viscosity = check("viscosity", viscosity)
        self.density = check("density", density)
        self.bulk_modulus = check("bulk_modulus", bulk_modulus)
        conductivity = check("conductivity", conductivity)
        permeability = check("permeability", permeability)
        if conductivity is not None and permeability is not None:
            raise InputError(f"{self.name}: give the hydraulic conductivity or the intrinsic "
                             f"permeability, not both (got conductivity={conductivity:g} m/s "
                             f"and permeability={permeability:g} m^2)", "permeability")
        if permeability is not None:
            conductivity = permeability * self.density * STANDARD_GRAVITY / self.viscosity
        self.conductivity = conductivity

    def __repr__(self):
        k = "None" if self.conductivity is None else f"{self.conductivity:g}"
        return (f"PoreWater(porosity={self.porosity:g}, conductivity={k}, "
                f"density={self.density:g}, bulk_modulus={self.bulk_modulus:g})")

    def parameters(self) -> dict:
        return {"porosity": self.porosity, "conductivity": self.conductivity,
                "density": self.density, "bulk_modulus": self.bulk_modulus}

    @property
    def storage_modulus(self) -> float:
        """K_w / n (Pa): the pore pressure's rise per unit of volumetric compression."""
        return self.bulk_modulus / self.porosity

    def drag(self, g: float = STANDARD_GRAVITY) -> float:
        """n rho_w g / k (kg / (m^3 s)): the drag per unit volume and relative velocity
        (water against skeleton); refused without a conductivity."""
        if self.conductivity is None:
            raise InputError(f"{self.name}: a coupled analysis needs the soil's hydraulic "
                             "conductivity (conductivity=, m/s) or its intrinsic permeability "
                             "(permeability=, m^2)", "conductivity")
        return self.porosity * self.density * g / self.conductivity

    def saturated_density(self, solid_density: float) -> float:
        """rho_sat = (1 - n) rho_s + n rho_w from the grains' density rho_s."""
        return (1.0 - self.porosity) * solid_density + self.porosity * self.density

    def undrained_wave_speed(self, constrained_modulus: float, saturated_density: float) -> float:
        """sqrt((E_oed + K_w / n) / rho_sat): the speed of a compression wave when the water
        moves with the skeleton (the bound on a coupled run's time step)."""
        return math.sqrt((constrained_modulus + self.storage_modulus) / saturated_density)
