"""The transfer schemes and the integrators, one file each, and their registries.

A scheme is the step of one particle-grid transfer written as a list of phases, each
under a one-line label (``Scheme.phases``), with the ``ti.func``s that make them; what it
owns (its parameters, its particle and grid fields) it declares in its own file
(:mod:`.base` states the contract):

- :mod:`.musl`: the study's Modified Lagrangian step (2.2.4, Euler-Cromer);
- :mod:`.pic_blend`: MUSL with a PIC share b of the velocity update (two MUSL functions
  changed);
- :mod:`.affine`: APIC (Jiang et al. 2015) and MLS-MPM (Hu et al. 2018);
- :mod:`.asflip`: APIC with FLIP shares of the velocity and position updates (Fei et al.
  2021);
- :mod:`.two_phase`: MUSL for a saturated soil whose pore water flows (the single-point
  two-phase formulation, Darcy's drag implicit at the nodes).

An integrator replaces a scheme's step by its own phases, calling the scheme's P2G and
gathers: :mod:`.rk4` (the classical Runge-Kutta method on the particles' equations) and
:mod:`.midpoint` (the energy-conserving midpoint iteration).

Every driver of the engine runs the list; the kinds of phase are in :mod:`.phases`.  A
new scheme is one file and one line in :data:`REGISTRY` (the first that applies to a
feature set is used: a variant before the scheme it changes); its ``transfers`` join the
names that the Model, the scene files and the command line accept (:data:`TRANSFERS`).
"""
from .affine import Affine
from .asflip import ASFLIP
from .base import OPERATIONS, Scheme
from .midpoint import Midpoint
from .musl import MUSL
from .phases import Nodes, Particles, Repeat, Scatter, Whole
from .pic_blend import PICBlend
from .rk4 import RungeKutta
from .two_phase import TwoPhase

__all__ = ["ASFLIP", "Scheme", "Scatter", "Particles", "Nodes", "Whole", "Repeat", "REGISTRY",
           "INTEGRATORS", "TRANSFERS", "OPERATIONS", "scheme_class", "scheme_classes",
           "scheme_params", "scheme_for"]

#: the transfer schemes, a variant before the scheme it changes
REGISTRY = (TwoPhase, PICBlend, MUSL, Affine, ASFLIP)
#: the integrators that replace a scheme's step, by ``Model.integrator`` (None: the scheme's
#: own Euler-Cromer step)
INTEGRATORS = {"euler-cromer": None, "rk4": RungeKutta, "midpoint": Midpoint}
#: the names of ``Model.transfer``, in the registry's order
TRANSFERS = tuple(dict.fromkeys(name for cls in REGISTRY for name in cls.transfers))


def scheme_classes(transfer):
    """The schemes that run transfer ``transfer`` (its variants first)."""
    return [cls for cls in REGISTRY if transfer in cls.transfers]


def scheme_params(transfer) -> dict:
    """The parameters the schemes of ``transfer`` declare, name -> Param."""
    out = {}
    for cls in reversed(scheme_classes(transfer)):
        out.update(cls.PARAMS)
    return out


def scheme_class(features):
    """The scheme a feature set runs."""
    for cls in REGISTRY:
        if cls.applies(features):
            return cls
    raise ValueError(f"no transfer scheme for transfer={features.transfer!r}")


def scheme_for(features, ops):
    """The step a feature set runs, made for it with the engine's operations ``ops``: its
    transfer scheme, or the integrator that wraps it."""
    transfer = scheme_class(features)(features, ops)
    integrator = INTEGRATORS[features.integrator]
    return transfer if integrator is None else integrator(features, ops, transfer)
