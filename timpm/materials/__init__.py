"""Constitutive models, one file each; :mod:`.base` states the contract they keep.

Materials for multi-dimensional scenes: :class:`LinearElastic`, :class:`NeoHookean`,
:class:`DruckerPrager` (sand, return mapping of Klar et al. 2016), :class:`MohrCoulomb`
(soil with cohesion, dilatancy and a tension cut-off), :class:`MohrCoulombSoftening` (its
strength softening with the plastic shear strain), :class:`MohrCoulombField` (its
strength particle by particle: a random field's realisation),
:class:`WeaklyCompressibleFluid` (Tait equation of state) and :class:`JFluid` (mpm88's
fluid).  :class:`Hypoelastic1D` is the study's 1D law (a :class:`timpm.model.scene.Scene` makes it from
its :class:`timpm.model.scene.Material`).  :class:`PoreWater` is the water in a saturated
body's pores, beside its law (not a law: the soil's law acts on the effective stress).
"""
from .base import Material, SolidMaterial
from .drucker_prager import DruckerPrager
from .fluid import WeaklyCompressibleFluid
from .hypoelastic import Hypoelastic1D
from .j_fluid import JFluid
from .linear_elastic import LinearElastic
from .mohr_coulomb import MohrCoulomb
from .mohr_coulomb_field import MohrCoulombField
from .mohr_coulomb_softening import MohrCoulombSoftening
from .neo_hookean import NeoHookean
from .pore_water import PoreWater

__all__ = ["Material", "SolidMaterial", "LinearElastic", "NeoHookean", "DruckerPrager", "MohrCoulomb",
           "MohrCoulombField", "MohrCoulombSoftening", "WeaklyCompressibleFluid", "JFluid", "Hypoelastic1D", "PoreWater", "MATERIALS", "get_material"]

MATERIALS = {cls.name: cls for cls in (LinearElastic, NeoHookean, DruckerPrager, MohrCoulomb,
                                       MohrCoulombSoftening, WeaklyCompressibleFluid, JFluid,
                                       Hypoelastic1D)}


def get_material(name: str, **params) -> Material:
    """A material by name: ``get_material("neo-hookean", E=1e3, nu=0.3, density=1e3)``."""
    if name not in MATERIALS:
        raise ValueError(f"unknown material {name!r}: choose one of {', '.join(MATERIALS)}")
    try:
        return MATERIALS[name](**params)
    except TypeError as err:
        raise ValueError(f"material {name!r}: {err}") from None
