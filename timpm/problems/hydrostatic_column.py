"""A saturated soil layer at rest under still water: the hydrostatic pore pressure and
the effective geostatic stress."""
from dataclasses import dataclass

import numpy as np

from ..materials.pore_water import PoreWater
from ..model.water import ANALYSES, Water
from ..platform.errors import InputError
from .k0_layer import K0Layer

__all__ = ["HydrostaticColumn"]


@dataclass(frozen=True)
class HydrostaticColumn(K0Layer):
    """The K0 layer (:class:`~timpm.problems.k0_layer.K0Layer`: Mohr-Coulomb, roller sides,
    a rigid base, plane strain) saturated and under ``water_depth`` of still water: the pore
    pressure is hydrostatic, p = rho_w |g| (h_w - y) with h_w = H + water_depth, and the
    stress effective, sigma_v' = (rho_sat - rho_w) |g| (H - y), sigma_h' = K0 sigma_v' (the
    K0 procedure on the buoyant weight).  That is the state at rest; the run (``analysis``
    "coupled" by default: the water may flow; "undrained", "drained") must keep it.  The
    record holds the relative RMS error of the pore pressure p = p_h + p_e against the
    hydrostatic one, of the effective stresses against the geostatic ones, the largest
    displacement and the largest excess pore pressure.
    """

    density: float = 2000.0      # saturated
    porosity: float = 0.4
    conductivity: float = 1.0e-5
    water_density: float = 1000.0
    water_modulus: float = 2.2e9
    water_depth: float = 5.0
    analysis: str = "coupled"

    name = "hydrostatic-column"
    title = "Saturated layer at rest under still water: hydrostatic pore pressure"
    section = "issue 44"

    def __post_init__(self):
        super().__post_init__()
        if self.analysis not in ANALYSES:
            raise InputError(f"{self.name}: analysis must be one of {', '.join(ANALYSES)}, "
                             f"got {self.analysis!r}", "analysis")
        if not (np.isfinite(self.water_depth) and self.water_depth >= 0.0):
            raise InputError(f"{self.name}: water_depth must be a depth >= 0 m (the still "
                             f"water above the ground), got {self.water_depth!r}", "water_depth")
        self.pore_water  # its own checks: porosity in (0, 1), positive properties

    @property
    def pore_water(self) -> PoreWater:
        return PoreWater(porosity=self.porosity, conductivity=self.conductivity,
                         density=self.water_density, bulk_modulus=self.water_modulus)

    @property
    def level(self) -> float:
        return self.H + self.water_depth

    def geostatic(self, x0):
        """sigma_v' and sigma_h' (> 0, compression): the buoyant weight above."""
        buoyant = self.density - self.water_density
        sv = buoyant * -self.gravity * (self.H - np.asarray(x0)[:, 1])
        return sv, self.k0_ratio * sv

    def hydrostatic(self, y):
        return self.water_density * -self.gravity * (self.level - np.asarray(y))

    def model_options(self, soil, h):
        water = self.pore_water
        wave = (soil.wave_speed if self.analysis == "drained" else
                np.sqrt(soil.wave_speed ** 2 + water.storage_modulus / soil.density))
        return dict(water=Water(self.analysis, level=self.level), pore_water=(water,)), wave

    def summary(self, x0, solver, stress_update) -> dict:
        out = super().summary(x0, solver, stress_update)
        y = solver.positions()[:, 1]
        p_ref = self.hydrostatic(y)
        excess = solver.read("pw") if self.analysis != "drained" else np.zeros(len(y))
        p = p_ref + excess
        # the effective stress: the grid's sigma' - p_e I plus p_e
        sig = solver.read("sigma") + excess[:, None, None] * np.eye(2)
        X = np.asarray(x0, dtype=float).reshape(-1, 2)
        sv, sh = self.geostatic(X)

        def rms(num, ref):
            return float(np.sqrt(np.mean(num ** 2) / np.mean(ref ** 2)))

        out.update(analysis=self.analysis, water_level=self.level,
                   pore_pressure_rms_error=rms(p - self.hydrostatic(X[:, 1]),
                                               self.hydrostatic(X[:, 1])),
                   sigma_v_rms_error=rms(-sig[:, 1, 1] - sv, sv),
                   sigma_h_rms_error=rms(-sig[:, 0, 0] - sh, sh),
                   max_excess_pore_pressure=float(np.abs(excess).max()))
        return out
