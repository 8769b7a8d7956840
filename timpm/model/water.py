"""The water of a scene: how its saturated bodies are analysed and where the free water
stands.  NumPy only.

A body carries :class:`~timpm.materials.pore_water.PoreWater` (its porosity, permeability
and the water's properties); the scene's :class:`Water` says what the engine computes:

- ``"drained"``: the pore pressure is the hydrostatic one of the still-water ``level``,
  p_h = rho_w |g| (level - y) below it, and the soil's law acts on the effective stress
  under the buoyant weight: the particles below the level carry the upward force rho_w V
  |g| (the hydrostatic pressure's gradient, which with the water's pressure on the
  submerged faces makes Archimedes' buoyancy).  No pore-pressure field is compiled.
- ``"undrained"``: besides, every saturated particle keeps an excess pore pressure p_e
  that its volumetric strain drives, dp_e = -(K_w / n) d eps_v (no flow); the stress the
  grid sees is sigma' - p_e I.
- ``"coupled"``: the single-point two-phase formulation (Anura3D's): the water has its
  own velocity, the excess pore pressure follows the volumetric strains of both phases,
  dp_e = -(K_w / n) [(1 - n) d eps_v,solid + n d eps_v,water], and Darcy's drag n rho_w g
  / k couples the two momentum balances at the nodes (implicitly: a low permeability does
  not shorten the time step).

Pore pressures are *excess* pressures over the hydrostatic one of ``level`` (zero
without a level): the total pore pressure is p = p_h + p_e, and a free surface, where the
excess vanishes, drains.  ``level`` is the still-water level along the up axis (y in 2D
and 3D, x in 1D), possibly above the ground (the sea over a seabed); None: no free water
(gravity off, as in Terzaghi's consolidation, or a dry scene).
"""
import math
from dataclasses import dataclass

from ..platform.errors import InputError

__all__ = ["Water", "ANALYSES"]

#: the analyses a scene's water may ask for, the cheapest first
ANALYSES = ("drained", "undrained", "coupled")


@dataclass(frozen=True)
class Water:
    """See the module: ``analysis`` one of ``ANALYSES``; ``level`` the still-water level
    (m, along the up axis) or None."""

    analysis: str = "coupled"
    level: float | None = None

    def __post_init__(self):
        if self.analysis not in ANALYSES:
            raise InputError(f"water: unknown analysis {self.analysis!r}: choose one of "
                             f"{', '.join(ANALYSES)}", "analysis")
        if self.level is not None:
            ok = (isinstance(self.level, (int, float)) and not isinstance(self.level, bool)
                  and math.isfinite(self.level))
            if not ok:
                raise InputError(f"water: level must be a finite height in m (or None: no "
                                 f"free water), got {self.level!r}", "level")
            object.__setattr__(self, "level", float(self.level))
        if self.analysis == "drained" and self.level is None:
            raise InputError("water: a drained analysis without a water level is a dry one: "
                             "give level= (the still-water level, m)", "level")

    @property
    def pore_pressure(self) -> bool:
        """Whether the particles keep an excess pore pressure (undrained, coupled)."""
        return self.analysis != "drained"
