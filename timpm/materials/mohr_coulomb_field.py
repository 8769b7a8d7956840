"""Mohr-Coulomb soil whose strength varies from particle to particle (a random field's
realisation, :mod:`timpm.model.random_field`)."""
import math

import numpy as np
import taichi as ti

from ..platform.declare import Field
from .mohr_coulomb import UNBOUNDED, MohrCoulomb

__all__ = ["MohrCoulombField"]


class MohrCoulombField(MohrCoulomb):
    """:class:`MohrCoulomb` with the cohesion and the friction angle of each particle its
    own: the surface particle ``p`` returns to is read from its ``strength`` field, (sin phi,
    sin psi, 2 c cos phi, c cot phi, the tension cut-off), which the scene gives
    (``Model(particle_values={"strength": ...})``, from :meth:`strength_values`); the
    elastic constants, the density and the dilation angle (psi = min(psi, phi) at each
    particle) are the material's, whose cohesion and friction angle are the field's means.

    A World builds it for a body with a random field (``Body(random_field=...)``); the
    same law with the same values everywhere steps as :class:`MohrCoulomb` does, bit for
    bit (the numbers are the same, read from a field instead of the constants).  An
    initial stress is set through the elastic strain as for MohrCoulomb, not checked
    against each particle's surface: a particle weaker than the mean that starts outside
    its own returns to it in the first step.
    """

    name = "mohr-coulomb-field"
    #: the fields a scene must give for every particle of the law (Model checks)
    GIVEN = ("strength",)

    @classmethod
    def of(cls, soil: MohrCoulomb) -> "MohrCoulombField":
        """The law of ``soil`` (its means) with its strength read per particle."""
        out = cls(E=soil.E, nu=soil.nu, density=soil.density,
                  friction_angle=soil.friction_angle, cohesion=soil.cohesion,
                  dilation_angle=soil.dilation_angle, tensile_strength=soil.tensile_strength)
        out.unreduced, out.factor = soil.unreduced, soil.factor  # (a reduced soil's)
        return out

    @classmethod
    def particle_fields(cls, dim):
        return {**super().particle_fields(dim),
                "strength": Field((5,), doc="the particle's surface: sin phi, sin psi, "
                                  "2 c cos phi, the apex c cot phi, the tension cut-off")}

    def strength_values(self, cohesion, friction_angle, factor=1.0) -> np.ndarray:
        """The ``strength`` field (m, 5) of particles of ``cohesion`` (Pa) and
        ``friction_angle`` (degrees) with their strength divided by ``factor`` (strength
        reduction: c / F, tan(phi) / F), psi = min(the unreduced material's psi, phi), the
        tension cut-off at most the apex (the unreduced material's divided by F; none: the
        apex)."""
        base = self.unreduced
        c = np.asarray(cohesion, dtype=np.float64)
        phi = np.radians(np.asarray(friction_angle, dtype=np.float64))
        if factor != 1.0:  # (F = 1: the material's own arithmetic, MohrCoulomb.constants)
            c, phi = c / factor, np.arctan(np.tan(phi) / factor)
        psi = np.minimum(math.radians(base.dilation_angle), phi)
        sin_phi = np.sin(phi)
        with np.errstate(divide="ignore", invalid="ignore"):
            apex = np.where(sin_phi > 0.0, c * np.cos(phi) / np.where(sin_phi > 0, sin_phi, 1),
                            UNBOUNDED)
        tension = apex if base.tensile_strength is None else np.minimum(
            base.tensile_strength / factor, apex)
        return np.stack([sin_phi, np.sin(psi), 2.0 * c * np.cos(phi), apex, tension], axis=-1)

    def initial_state(self, stress, dim):
        F, ezz = self._hencky_state(stress, dim)  # (each particle's surface: see the class)
        return {"F": F, "ezz": ezz} if dim == 2 else {"F": F}

    @ti.func
    def strength(self, s: ti.template(), p):
        k = s.strength[p]
        return k[0], k[1], k[2], k[3], k[4]
