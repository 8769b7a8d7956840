"""The interface of a basis: a small class of compile-time constants and one ``@ti.func``

    base, w, dw = Basis.stencil(xi, n_elements)

``xi`` is a particle coordinate along one axis in element units (``(x - origin) / h``);
the particle touches the ``support`` nodes ``base, base + 1, ..., base + support - 1``
with values ``w[a]`` and derivatives ``dw[a]`` (per element length: divide by ``h``).
The engine takes the class as a compile-time parameter, so every basis compiles its own
kernels with the stencil unrolled (``ti.static(range(support))``); multi-dimensional
stencils are tensor products of this one-dimensional stencil.
"""
import numpy as np

__all__ = ["Basis", "BasisType"]


class BasisType(type):
    """The type of the basis classes: a model, a scene and the engine carry the class
    itself, resolved from its name once where the name is read; it prints as its name
    and pickles by it (a sweep's worker rebuilds a B-spline of any degree)."""

    def __repr__(cls):
        return f"<basis {cls.name}>" if cls.name else super().__repr__()


class Basis(metaclass=BasisType):
    """Interface of a one-dimensional basis (documentation and defaults)."""

    #: name used on the command line and in result records
    name = ""
    #: number of nodes a particle touches along one axis
    support = 0
    #: grid nodes per element along one axis (2 for the quadratic Lagrange basis)
    nodes_per_element = 1
    #: direct lumping (study A.2) needs non-negative basis functions
    lumpable = True
    #: smallest number of elements the basis is defined on
    min_elements = 1
    #: fewest particles per element its quadrature needs (mass and stiffness of full rank)
    min_ppc = 1
    #: tensor products of it span 2D and 3D grids
    nd = False
    #: node j stands at x = (j - offset) h, uniformly spaced: the node positions the affine
    #: transfers (APIC, MLS-MPM) take for x_i - x_p
    uniform_nodes = False
    #: its functions are only continuous (C0): they reach the support's edge with a slope,
    #: so (grad phi)^2 / phi grows without bound at a node the body barely reaches (the
    #: coupled step floors its water's mass there: schemes/two_phase.py)
    kinked = False

    @classmethod
    def n_nodes(cls, n_elements: int) -> int:
        """Number of grid nodes (unknowns) along one axis."""
        raise NotImplementedError

    @classmethod
    def node_coordinates(cls, n_elements: int) -> np.ndarray:
        """Node (or control point) positions in element units, for plotting and Dirichlet."""
        raise NotImplementedError

    @classmethod
    def boundary_nodes(cls, n_elements: int):
        """Nodes to hold for a zero Dirichlet value at the left and at the right end."""
        return (0,), (cls.n_nodes(n_elements) - 1,)
