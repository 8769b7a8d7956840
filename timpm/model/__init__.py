"""The model: one checked, immutable description of a simulation in 1, 2 or 3 dimensions
(:mod:`.model`), and what builds it: the study's 1D scenes (:mod:`.scene`), bodies in a box
(:mod:`.world`) with polygon and prism shapes (:mod:`.geometry`), loads (:mod:`.loads`),
walls on a box's sides and plane walls at any angle (:mod:`.walls`) and initial stresses
of the ground (:mod:`.geostatic`).

NumPy only: no kernel runs here.  It imports the platform and the components it checks
against (the bases, the materials, the transfer schemes' declarations), never the engine
(``tests/test_layers.py``).  ``from timpm.model import Model`` gives the model itself.
"""
from .model import (CRITICAL_STEP_FACTOR, INTEGRATORS, MASS_KINDS, ND_BASES, PROJECTIONS, SIDES,
                    TRANSFERS, WALL_KINDS, PLANE_KINDS, Model, Plane, Wall, check_scheme,
                    pic_applies, walls_from)

__all__ = ["Model", "Wall", "Plane", "PLANE_KINDS", "walls_from", "check_scheme", "pic_applies",
           "SIDES", "WALL_KINDS", "ND_BASES", "TRANSFERS", "MASS_KINDS", "PROJECTIONS", "INTEGRATORS",
           "CRITICAL_STEP_FACTOR"]
