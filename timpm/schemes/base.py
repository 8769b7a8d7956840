"""The frame every transfer scheme fills in: what it declares it owns, and the operations
it is given.

A scheme class declares, beside its step (``phases``):

- ``transfers``: the names of ``Model.transfer`` it runs (the registry's entries make the
  list the command line, the scene files and the Model accept); ``applies(features)``
  picks it among the schemes of one name (a variant before the scheme it changes);
- ``PARAMS``: its parameters, name -> :class:`~timpm.platform.declare.Param` (default,
  unit, meaning, range): given as ``transfer_params`` (Python),
  ``[simulation.transfer_params]`` (scene files) or ``--transfer-param NAME=VALUE`` (the
  command line), checked by the Model, read in kernels as run-time values
  (``values.alpha()``);
- ``particle_fields(features)`` and ``grid_fields(features)``: the state it keeps per
  particle and per node, name -> :class:`~timpm.platform.declare.Field` (grid fields by
  their storage name, ``engine/grid.py``'s ``NODE_NAMES``); the engine allocates the union
  of the scheme's, the laws' and its own;
- ``check(transfer, dim, basis, mass, projection, damping, params)``: what else a model
  must satisfy for it (a basis, a mass matrix), checked with the Model.

The engine builds it with the feature set and the operations its phases call (``ops``):
the stencil, the scatter, the boundary conditions (``boundary``), the grid's clearing and
mass solves (``nodes``), the consistent mass (``banded`` in 1D, ``cg`` in 2D and 3D), the MLS
projections (``mls``, ``mls_nd``), the loads, the shared G2P update (``g2p``), the laws and the
failure record.  Its phases receive the state they read as arguments: the particle fields,
the grid fields (``particles.v[p]``, ``grid.node_mass[I]``) and the run-time values
(``values.dt()``); never the program (``tests/test_layers.py``).
"""

__all__ = ["Scheme", "OPERATIONS"]

#: the operations a scheme is given (the engine's units), by the name it holds them under
OPERATIONS = ("stencil", "scatter", "boundary", "nodes", "banded", "cg", "mls", "mls_nd",
              "loads", "g2p", "laws", "failures")


class Scheme:
    """See the module."""

    #: the names of ``Model.transfer`` this scheme runs
    transfers = ()
    #: an affine transfer (an affine velocity C_p, the forces folded into the momentum)
    affine = False
    #: its parameters: name -> Param
    PARAMS = {}
    #: the integrators (``Model.integrator``) that may replace its step: an integrator
    #: calls the scheme's P2G and gathers and makes its own G2P, so a scheme whose update
    #: is its own (a new one, until an integrator is taught it) takes only its own step
    integrators = ("euler-cromer",)

    @classmethod
    def applies(cls, features) -> bool:
        """Whether this scheme runs the feature set (the first in the registry that does)."""
        return features.transfer in cls.transfers

    @classmethod
    def check(cls, transfer, dim, basis, mass, projection, damping, params) -> None:
        """Refuse (ValueError, naming the conflict) what this scheme does not take: the
        ``transfer`` it runs under in ``dim`` dimensions with the ``basis`` class, the mass
        matrix, the projection, the local damping and its checked ``params``."""

    @staticmethod
    def particle_fields(features) -> dict:
        """Per-particle state of its own: name -> Field."""
        return {}

    @staticmethod
    def grid_fields(features) -> dict:
        """Per-node state of its own, by storage name: name -> Field."""
        return {}

    def __init__(self, features, ops):
        self.f = features
        for name in OPERATIONS:
            setattr(self, name, getattr(ops, name))

    def phases(self) -> tuple:
        """The step: a tuple of phases (``schemes.phases``) under one-line labels."""
        raise NotImplementedError
