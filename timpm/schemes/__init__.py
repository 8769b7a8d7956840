"""The transfer schemes, one file each, and the phases a driver runs.

A scheme is the step of one particle-grid transfer written as a list of phases, each
under a one-line label (``Scheme.phases``), with the ``ti.func``s that make them:

- :mod:`.musl`: the study's Modified Lagrangian step (2.2.4, Euler-Cromer);
- :mod:`.affine`: APIC (Jiang et al. 2015) and MLS-MPM (Hu et al. 2018);
- :mod:`.pic_blend`: MUSL with a PIC share b of the velocity update, written as a change
  of two MUSL functions.

A phase receives the state it reads as arguments: the particle fields and the grid fields
by name (``particles.v``, ``grid.node_mass``: :class:`~timpm.engine.views.FieldView`) and
the run-time values (``values.dt()``), beside the program whose units it calls (the
stencil of a position, the scatter, the mass solves, the walls, the failure record, the
shared G2P update and external force of :mod:`timpm.engine.transfer`, which receive the
state too; a material's law gets the particle state alone,
:class:`~timpm.engine.views.MaterialState`).  ``tests/test_layers.py`` checks that no
scheme reads a field through the program.

Every driver (``engine/drivers.py``) runs the same list: one launch per step with each
phase its parallel loop, the fused serial loop, or a team of threads with a barrier
between two phases.  The kinds of phase are in :mod:`.phases`.

A new scheme is one file, with a class whose ``applies(features)`` says when it runs (its
``PARAMS``: run-time values of its own, taken from the Model's attributes of those names;
``grid_fields``: fields of its own), and one line in :data:`REGISTRY` (the first that
applies is used).
"""
from .affine import Affine
from .musl import MUSL
from .phases import Nodes, Particles, Scatter, Whole
from .pic_blend import PICBlend

__all__ = ["Scatter", "Particles", "Nodes", "Whole", "REGISTRY", "scheme_class", "scheme_for"]

#: the schemes, a variant before the scheme it changes
REGISTRY = (PICBlend, MUSL, Affine)


def scheme_class(features):
    """The scheme a feature set runs."""
    for cls in REGISTRY:
        if cls.applies(features):
            return cls
    raise ValueError(f"no transfer scheme for transfer={features.transfer!r}")


def scheme_for(features):
    """The scheme a feature set runs, made for it (its functions read the features)."""
    return scheme_class(features)(features)
