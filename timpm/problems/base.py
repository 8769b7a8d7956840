"""Common frame of the study's benchmark problems: a scene builder and an exact solution."""
from dataclasses import dataclass, fields, replace

import numpy as np

from ..bases import get_basis
from ..platform.checks import check_size
from ..platform.errors import InputError
from ..model.model import CRITICAL_STEP_FACTOR, pic_applies
from ..model.scene import Grid1D, Material, Scene, equidistant_particles

__all__ = ["Problem", "ProblemScene", "lattice"]


@dataclass(frozen=True)
class Problem:
    """A benchmark: physical parameters (a frozen dataclass) plus numerical defaults.

    Subclasses set ``name``, the defaults ``elements``, ``ppc``, ``dt``, ``t_end`` and
    implement :meth:`scene` and, where one exists, :meth:`displacement` (the exact
    solution at initial positions ``x0`` and time ``t``).
    """

    name = ""
    title = ""
    section = ""
    elements = 16
    ppc = 2
    dt = 1e-3
    t_end = 1.0
    #: particle positions in an element (``timpm.model.scene.PLACEMENTS``)
    placement = "study"
    #: dimensions of its scenes
    dim = 1
    has_exact = True
    #: the body's end at x = L is free: the grid reaches beyond it so that the end may
    #: move out without leaving the grid, and away from the boundary-fitted basis there
    free_end = False
    #: the PIC share of the MUSL velocity update (0: FLIP, the study's)
    pic_fraction = 0.0

    def scheme(self, basis, mass=None, projection=None, integrator=None, transfer="musl"):
        """The mass matrix, projection and time integration of a run, the problem's
        defaults where None: the study's (lumped, standard, euler-cromer)."""
        return (mass or "lumped", projection or "standard", integrator or "euler-cromer")

    def with_params(self, **params):
        """A copy with some physical parameters changed (names are checked; a whole
        number given for an integer parameter, 4000.0 from a command line, is taken as
        an int; the problem refuses a fraction)."""
        known = {f.name: f for f in fields(self)}
        unknown = set(params) - set(known)
        if unknown:
            raise ValueError(f"{self.name} has no parameter {', '.join(sorted(unknown))}; "
                             f"its parameters are {', '.join(sorted(known))}")
        params = {k: int(v) if known[k].type in (int, "int") and isinstance(v, float)
                  and v.is_integer() else v for k, v in params.items()}
        for k, v in params.items():
            words = known[k].type in (str, "str")
            if words != isinstance(v, str):
                raise ValueError(f"{self.name}: parameter {k} must be "
                                 f"{'a word' if words else 'a number'}, got {v!r}")
        return replace(self, **params)

    def check_size(self, elements, ppc) -> None:
        """Refuse, before anything is allocated, a discretisation too large to index or
        for the memory available (:func:`timpm.platform.checks.check_size`): ``elements`` elements
        along each axis of the body, ``ppc`` particles per element and axis."""
        if all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v > 0
               for v in (elements, ppc)):
            cells = self.cells(int(elements))
            check_size(f"{self.name} with {elements} elements and {ppc} particles per element",
                       np.prod([float(c) * ppc for c in cells]),
                       np.prod([float(c) + 1 for c in cells]), self.dim)

    def cells(self, elements: int) -> tuple:
        """Elements along each axis of the body for ``elements`` along its length."""
        return (elements,) * self.dim

    @property
    def material(self) -> Material:
        """The linear elastic material of the problem's E and density."""
        return Material(self.E, self.density)

    def domain_length(self) -> float:
        """Length of the body along x (the part filled with particles)."""
        raise NotImplementedError

    def grid(self, elements: int, basis) -> Grid1D:
        """The background grid: ``elements`` elements over the body (more where needed)."""
        if isinstance(elements, bool) or not isinstance(elements, (int, np.integer)) or elements <= 0:
            raise ValueError(f"number of elements must be a positive integer, got {elements!r}")
        pad = max(1, get_basis(basis).support - 1) if self.free_end else 0
        return Grid1D(int(elements) + pad, self.domain_length() / elements)

    def particles(self, elements: int, ppc: int, placement: str):
        h = self.domain_length() / elements
        return equidistant_particles(elements, ppc, h, placement=placement)

    @property
    def dt_rule(self) -> str:
        """The default time step, as ``timpm list`` shows it."""
        return f"{self.dt:g} s"

    def numerics(self, elements, ppc, placement, basis):
        """Elements, particles per element, placement (the problem's defaults where None)
        and the basis class, the particle count checked against the basis' quadrature."""
        elements = self.elements if elements is None else elements
        ppc = self.ppc if ppc is None else ppc
        placement = self.placement if placement is None else placement
        basis_cls = get_basis(basis)
        self.check_size(elements, ppc)
        if isinstance(ppc, (int, np.integer)) and 0 < ppc < basis_cls.min_ppc:
            raise ValueError(f"the {basis_cls.name} basis needs at least {basis_cls.min_ppc} "
                             f"particles per element for its quadrature, got ppc = {ppc}")
        return elements, ppc, placement, basis_cls

    def transfer_choice(self, transfer, mass, projection, pic_fraction=None,
                        transfer_params=None):
        """``(pic_fraction, transfer_params)`` of a run: as given (the Model checks them;
        ``pic_fraction`` is the musl transfer's parameter of that name, given on its own),
        the problem's :attr:`pic_fraction` where neither gives one and it applies (MUSL,
        lumped mass, standard projection)."""
        given = transfer_params if isinstance(transfer_params, dict) else {}
        if pic_fraction is None and "pic_fraction" not in given:
            pic_fraction = self.pic_fraction if pic_applies(transfer, mass, projection) else 0.0
        return (0.0 if pic_fraction is None else pic_fraction), transfer_params

    def scene(self, elements=None, ppc=None, basis="linear", mass=None, dt=None,
              placement=None, stress_update="study", allow_unstable_dt=False,
              damping=None, projection=None, transfer="musl",
              pic_fraction=None, integrator=None, transfer_params=None) -> Scene:
        """The problem's scene with ``elements`` elements over the body and ``ppc``
        particles per element placed by ``placement``; unset values take the defaults
        (``transfer_params`` and ``pic_fraction``: :meth:`transfer_choice`; mass,
        projection and integrator: :meth:`scheme`)."""
        elements, ppc, placement, basis_cls = self.numerics(elements, ppc, placement, basis)
        mass, projection, integrator = self.scheme(basis_cls, mass, projection, integrator,
                                                   transfer)
        dt = self.dt if dt is None else dt
        grid = self.grid(elements, basis_cls)
        x, vol = self.particles(elements, ppc, placement)
        material = replace(self.material, stress_update=stress_update)
        extras = self.conditions(x, basis_cls, grid)
        if damping is not None:
            extras["damping"] = damping
        pic_fraction, transfer_params = self.transfer_choice(transfer, mass, projection,
                                                             pic_fraction, transfer_params)
        return Scene(grid=grid, material=material, positions=x, volume=vol, dt=dt,
                     basis=basis_cls, mass=mass, allow_unstable_dt=allow_unstable_dt,
                     projection=projection, transfer=transfer, pic_fraction=pic_fraction,
                     transfer_params=transfer_params, integrator=integrator, name=self.name,
                     **extras)

    def conditions(self, x0, basis, grid) -> dict:
        """Initial velocity, boundary conditions and loads as Scene keyword arguments."""
        raise NotImplementedError

    def displacement(self, x0, t, stress_update="study"):
        """Exact displacement at initial positions ``x0`` and time ``t`` (only the
        oedometer's static solution depends on the stress update)."""
        raise NotImplementedError(f"{self.name} has no exact solution")

    def velocity(self, x0, t):
        """Exact velocity at initial positions ``x0`` and time ``t``."""
        raise NotImplementedError(f"{self.name} has no exact solution")

    def summary(self, x0, solver, stress_update) -> dict:
        """Problem-specific numbers added to a run's record."""
        return {}

    def monitored_particle(self, x0) -> int:
        """The particle whose time series the study plots."""
        return int(np.argmin(np.abs(np.asarray(x0) - 0.5 * self.domain_length())))


def last_below(x0, y):
    """Index of the particle with the largest initial position below ``y``."""
    x0 = np.asarray(x0)
    below = np.flatnonzero(x0 < y)
    return int(below[np.argmax(x0[below])])


def check_positive(problem, *names):
    """Raise a clear error for a non-positive or non-finite physical parameter."""
    for name in names:
        value = getattr(problem, name)
        if isinstance(value, bool) or not np.isfinite(value) or value <= 0:
            raise InputError(f"{problem.name}: parameter {name} must be positive, got "
                             f"{value!r}", name)


def lattice(cells, ppc, h, placement):
    """Positions (n, dim) and volumes of ``ppc`` particles per cell and axis, placed by
    ``placement`` (``timpm.model.scene.PLACEMENTS``) in ``cells[k]`` cells of size h from 0
    along axis k: tensor products of the 1D placement (its size checked first)."""
    check_size(f"a lattice of {' x '.join(map(str, cells))} cells, {ppc} particles per cell "
               "and axis", np.prod([float(c) * ppc for c in cells]),
               np.prod([float(c) + 1 for c in cells]), len(cells))
    xs, vs = zip(*(equidistant_particles(c, ppc, h, placement=placement) for c in cells))
    X = np.stack([a.ravel() for a in np.meshgrid(*xs, indexing="ij")], axis=1)
    volume = np.prod(np.stack([v.ravel() for v in np.meshgrid(*vs, indexing="ij")], axis=1),
                     axis=1)
    return X, volume


class ProblemScene:
    """A problem's model with what a study reports of it (``positions`` are (n,) in 1D);
    a time step above ``critical_dt`` (``rule``: how it was found) is refused unless
    ``allow_unstable_dt``."""

    def __init__(self, model, critical_dt, rule, allow_unstable_dt=False):
        if model.integrator != "euler-cromer":  # Euler-Cromer's bound times the method's
            critical_dt *= CRITICAL_STEP_FACTOR[model.integrator]
            rule += f", times {CRITICAL_STEP_FACTOR[model.integrator]:.4g} for {model.integrator}"
        if model.dt > critical_dt and not allow_unstable_dt:
            raise ValueError(f"time step dt = {model.dt:g} s exceeds the critical time step "
                             f"{critical_dt:g} s ({rule}, h = {model.h:g} m) of {model.name}; "
                             "choose a smaller dt or pass allow_unstable_dt=True")
        self.model = model
        self.critical_dt = float(critical_dt)
        self.positions = model.positions[:, 0] if model.dim == 1 else model.positions
        self.volume = model.volume
        self.dt, self.basis, self.mass = model.dt, model.basis, model.mass_matrix
        self.damping, self.n_particles = model.damping, model.n_particles
