"""1D scenes: the grid, the particles, the material, loads and boundaries of the study.

A :class:`Scene` is a checked, immutable description of one 1D simulation and a builder
of the one model of 1D to 3D (:class:`timpm.model.Model`, ``scene.model``), which the
engine reads.  Every value is validated when the scene is built, with an error that names
the parameter, so a solver never starts on bad input.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..bases import Basis, get_basis
from ..platform.checks import check_size, finite, positive as _positive, positive_int as _positive_int
from .loads import Constant, Ramp, Sine, Traction
from ..materials import Hypoelastic1D
from .model import (CRITICAL_STEP_FACTOR, MASS_KINDS, PROJECTIONS, Model, walls_from,
                    with_pic_fraction)

__all__ = [
    "Material", "Grid1D", "Traction", "Constant", "Sine", "Ramp", "Scene",
    "equidistant_particles", "PLACEMENTS", "critical_time_step", "MASS_KINDS", "PROJECTIONS",
]


STRESS_UPDATES = ("study", "small", "study-exact", "small-exact")


@dataclass(frozen=True)
class Material:
    """Linear elastic material of the study.

    ``stress_update="study"`` is the update of section 2.2.4,
    sigma += (E - sigma) * d_eps, which integrates to sigma = E (1 - 1/stretch) and gives
    the large-deformation oedometer strain ln(1 + p0/E) (A.4); ``"small"`` is the plain
    small-strain update sigma += E * d_eps.  ``"study-exact"`` and ``"small-exact"`` are
    the same laws integrated exactly over each step (sigma = E (1 - 1/F), sigma = E ln F
    with F = V / V0; :class:`~timpm.materials.Hypoelastic1D`): no drift of the mean
    stress over long runs, and the records report the stored energy W(F) V0.
    """

    E: float
    density: float
    stress_update: str = "study"

    def __post_init__(self):
        object.__setattr__(self, "E", _positive("Young's modulus E", self.E))
        object.__setattr__(self, "density", _positive("density", self.density))
        if self.stress_update not in STRESS_UPDATES:
            raise ValueError(f"unknown stress_update {self.stress_update!r}: choose one of "
                             f"{', '.join(STRESS_UPDATES)}")

    @property
    def wave_speed(self) -> float:
        return math.sqrt(self.E / self.density)

    def law(self) -> Hypoelastic1D:
        """The constitutive law the engine compiles: :class:`~timpm.materials.Hypoelastic1D`."""
        law, _, integration = self.stress_update.partition("-")
        return Hypoelastic1D(self.E, self.density, study=law == "study",
                             exact=integration == "exact")


@dataclass(frozen=True)
class Grid1D:
    """A uniform 1D background grid of ``n_elements`` elements of size ``h`` from ``origin``."""

    n_elements: int
    h: float
    origin: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "n_elements", _positive_int("number of elements", self.n_elements))
        object.__setattr__(self, "h", _positive("element size h", self.h))
        if not math.isfinite(float(self.origin)):
            raise ValueError(f"grid origin must be finite, got {self.origin!r}")

    @property
    def length(self) -> float:
        return self.n_elements * self.h

    @property
    def end(self) -> float:
        return self.origin + self.length


# ---- particle placement --------------------------------------------------------------------

def _study_positions(ppc):
    return (np.arange(ppc) + 1.0) / (ppc + 1.0)


def _centered_positions(ppc):
    return (np.arange(ppc) + 0.5) / ppc


def _gauss_positions(ppc):
    return (np.polynomial.legendre.leggauss(ppc)[0] + 1.0) / 2.0


#: local positions of ``ppc`` particles in an element, in [0, 1]
PLACEMENTS = {"study": _study_positions, "centered": _centered_positions, "gauss": _gauss_positions}


def equidistant_particles(n_elements: int, ppc: int, h: float, start: float = 0.0,
                          placement: str = "study"):
    """Particle positions and volumes filling ``n_elements`` elements from ``start``.

    ``placement="study"`` puts the particles of an element at ``(k + 1) / (ppc + 1)``, equal
    gaps between neighbours and to the element edges; this is the spacing that reproduces
    the study's Table 3.2.  ``"centered"`` uses ``(k + 1/2) / ppc`` (each particle in the
    middle of an equal sub-cell), ``"gauss"`` the Gauss-Legendre points with their weights
    as volumes.  Volumes sum to the filled length in every case.  A size that cannot be
    indexed or held in memory is refused first (:func:`timpm.platform.checks.check_size`).
    """
    n_elements = _positive_int("number of elements", n_elements)
    ppc = _positive_int("particles per element", ppc)
    check_size(f"{n_elements} elements of {ppc} particles", n_elements * ppc, n_elements + 1, 1)
    h = _positive("element size h", h)
    if placement not in PLACEMENTS:
        raise ValueError(f"unknown placement {placement!r}: choose one of {', '.join(PLACEMENTS)}")
    local = PLACEMENTS[placement](ppc)
    x = start + (np.arange(n_elements)[:, None] + local[None, :]).ravel() * h
    if placement == "gauss":
        weights = np.polynomial.legendre.leggauss(ppc)[1] / 2.0
    else:
        weights = np.full(ppc, 1.0 / ppc)
    volume = np.tile(weights, n_elements) * h
    return x, volume


def critical_time_step(h: float, material: Material) -> float:
    """Eq. 2.4 of the study: dt <= h / sqrt(E / rho) (linear elements, lumped mass)."""
    return h / material.wave_speed


#: above this many nodes the consistent-mass eigenproblem is bounded element by element
DENSE_EIGEN_LIMIT = 1500


def particle_matrices(grid: Grid1D, material: Material, basis, positions, volume):
    """Per-particle stencil contributions to K = sum_p E V_p dphi dphi^T and
    M = sum_p m_p phi phi^T (A.1, A.3), from the basis' own stencil: returns the node base
    of each particle and arrays k, m of shape (particles, support, support)."""
    from ..bases import stencils

    basis = get_basis(basis)
    xi = (np.asarray(positions) - grid.origin) / grid.h
    base, w, dw = stencils(basis, xi, grid.n_elements)
    vol = np.asarray(volume)
    m = material.density * vol[:, None, None] * w[:, :, None] * w[:, None, :]
    k = material.E * vol[:, None, None] * dw[:, :, None] * dw[:, None, :] / grid.h ** 2
    return base, k, m


def _window(rows, blocks, lo, hi):
    """Dense block [lo, hi) x [lo, hi) of the matrix assembled from per-particle blocks."""
    near = (rows[:, -1] >= lo) & (rows[:, 0] < hi)  # particles whose stencil meets the window
    rows, blocks = rows[near], blocks[near]
    r = np.broadcast_to(rows[:, :, None], blocks.shape)
    c = np.broadcast_to(rows[:, None, :], blocks.shape)
    inside = (r >= lo) & (r < hi) & (c >= lo) & (c < hi)
    out = np.zeros((hi - lo, hi - lo))
    np.add.at(out, (r[inside] - lo, c[inside] - lo), blocks[inside])
    return out


def discrete_critical_time_step(grid: Grid1D, material: Material, basis, positions, volume,
                                mass: str, fixed_nodes=()) -> float:
    """Critical Euler-Cromer step dt = 2 / w_max of the particle discretisation.

    w_max^2 is the largest eigenvalue of K x = w^2 M x on the free, non-empty nodes.  For
    the lumped mass (diagonal row sums) the Gershgorin bound max_i sum_j |K_ij| / M_ii is
    used, which is Eq. 2.4 for linear elements.  For the consistent mass the eigenproblem
    is solved, above DENSE_EIGEN_LIMIT nodes on overlapping windows of nodes (the highest
    modes are local).  A singular or indefinite mass has no stable step: 0 is returned.
    """
    basis = get_basis(basis)
    base, k, m = particle_matrices(grid, material, basis, positions, volume)
    nn, s = basis.n_nodes(grid.n_elements), basis.support
    free = np.ones(nn, dtype=bool)
    free[list(fixed_nodes)] = False
    rows = (base[:, None] + np.arange(s)[None, :])
    if mass == "lumped":
        lumped = np.bincount(rows.ravel(), m.sum(axis=2).ravel(), minlength=nn)
        band = np.zeros((nn, 2 * s - 1))  # |K| row sums need K itself, assembled banded
        cols = np.arange(s)[None, None, :] - np.arange(s)[None, :, None] + s - 1
        np.add.at(band, (np.broadcast_to(rows[:, :, None], k.shape), np.broadcast_to(cols, k.shape)), k)
        active = free & (lumped != 0)
        if np.any(lumped[active] < 0):
            return 0.0
        w2 = np.max(np.abs(band[active]).sum(axis=1) / lumped[active])
    else:
        touched = np.bincount(rows.ravel(), minlength=nn) > 0
        # the highest modes are local: above DENSE_EIGEN_LIMIT nodes, overlapping windows
        size = nn if nn <= DENSE_EIGEN_LIMIT else DENSE_EIGEN_LIMIT // 3
        w2 = 0.0
        for lo in range(0, max(nn - size // 2, 1), max(size // 2, 1)):
            hi = min(nn, lo + size)
            keep = (free & touched)[lo:hi]
            if not keep.any():
                continue
            K, M = _window(rows, k, lo, hi), _window(rows, m, lo, hi)
            K, M = K[np.ix_(keep, keep)], M[np.ix_(keep, keep)]
            lam = np.linalg.eigvalsh(M)
            if lam.min() <= 1e-12 * lam.max():
                return 0.0
            L = np.linalg.cholesky(M)
            A = np.linalg.solve(L, np.linalg.solve(L, K).T)
            w2 = max(w2, np.linalg.eigvalsh(0.5 * (A + A.T)).max())
    return float(2.0 / np.sqrt(w2)) if w2 > 0 else float("inf")


def consistent_mass_ratio(grid: Grid1D, basis, positions, volume) -> float:
    """The smallest eigenvalue of M_L^-1 M on one axis, M the consistent particle mass
    matrix and M_L its lumping (unit density).  On a tensor lattice of particles the 2D or
    3D matrices are Kronecker products of the axes': the product of the axes' ratios bounds
    the consistent step from the lumped one, w_max^2(M) <= w_max^2(M_L) / that product
    (the Rayleigh quotient x'Kx / x'Mx is x'Kx / x'M_L x times x'M_L x / x'Mx)."""
    basis = get_basis(basis)
    base, _, m = particle_matrices(grid, Material(1.0, 1.0), basis, positions, volume)
    nn = basis.n_nodes(grid.n_elements)
    rows = base[:, None] + np.arange(basis.support)[None, :]
    M = _window(rows, m, 0, nn)
    lumped = M.sum(axis=1)
    keep = lumped > 0
    M, lumped = M[np.ix_(keep, keep)], lumped[keep]
    scale = 1.0 / np.sqrt(lumped)
    return float(np.linalg.eigvalsh(scale[:, None] * M * scale[None, :]).min())


@dataclass(frozen=True, eq=False)
class Scene:
    """One 1D MPM simulation (the study's problems), checked on construction: a builder of
    the one :class:`~timpm.model.Model` of 1D to 3D (``scene.model``).

    Positions are absolute coordinates; ``volume`` the initial particle volumes (length
    times a unit cross-section); ``fixed_nodes`` the grid nodes held at zero velocity, or
    a dict of node to prescribed velocity (times the time function ``fixed_time``);
    ``walls`` walls at the grid's ends: one for both (``"slip"``, ``"sticky"``, a friction
    coefficient, a :class:`~timpm.model.Wall`) or a dict ``{"left": ..., "right": ...}``,
    None for no wall (lumped mass, standard projection); ``gravity`` the signed
    acceleration along x (negative points down); ``damping`` the local damping factor
    alpha of A.4; ``transfer_params`` the transfer scheme's parameters, ``pic_fraction`` the
    PIC share of the MUSL velocity update among them (see :class:`~timpm.model.Model`); ``projection`` the particle-to-grid projection (``PROJECTIONS``);
    ``transfer`` the particle-grid transfer (the study's ``"musl"``, or the affine
    ``"apic"`` and ``"mls-mpm"`` with uniformly spaced nodes); ``displacement`` a function
    u0(X) the body starts displaced by (see :class:`~timpm.model.Model`); ``integrator``
    the time integration (``timpm.model.INTEGRATORS``).  A saturated column: ``pore_water``
    (:class:`~timpm.materials.pore_water.PoreWater`), ``water`` (the analysis,
    :class:`~timpm.model.water.Water`) and ``initial_pore_pressure`` (per particle); the
    critical time step then takes the undrained stiffness E + K_w / n.
    """

    grid: Grid1D
    material: Material
    positions: np.ndarray
    volume: np.ndarray
    dt: float
    velocity: np.ndarray | None = None
    basis: "str | type[Basis]" = "linear"  # a name or a Basis class; the class once checked
    mass: str = "lumped"
    gravity: float = 0.0
    traction: Traction | None = None
    fixed_nodes: tuple = ()
    damping: float = 0.0
    pic_fraction: float = 0.0
    transfer_params: dict | None = None
    projection: str = "standard"
    walls: object = None
    allow_unstable_dt: bool = False
    name: str = "scene"
    transfer: str = "musl"
    fixed_time: object = None
    displacement: object = None
    integrator: str = "euler-cromer"
    pore_water: object = None
    water: object = None
    initial_pore_pressure: object = None

    def __post_init__(self):
        basis = get_basis(self.basis)
        object.__setattr__(self, "basis", basis)
        if not isinstance(self.grid, Grid1D):
            raise ValueError(f"a Scene's grid must be a Grid1D, got {self.grid!r}")
        if not isinstance(self.material, Material):
            raise ValueError(f"a Scene's material must be a timpm.Material (E, density), got "
                             f"{self.material!r}")
        for i in self.fixed_nodes:  # node indices, or the keys of {node: velocity}
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)):
                raise ValueError(f"fixed node {i!r} must be a whole number (a node index)")
        fixed_nodes = (dict(self.fixed_nodes) if isinstance(self.fixed_nodes, dict)
                       else tuple(self.fixed_nodes))
        finite("gravity", self.gravity)
        walls = None if self.walls is None else walls_from(self.walls, 1, default=None,
                                                             open_ok=True)
        model = Model(basis=basis, origin=(self.grid.origin,), h=self.grid.h,
                      elements=(self.grid.n_elements,), positions=self.positions,
                      volume=self.volume, velocity=self.velocity,
                      materials=(self.material.law(),), dt=self.dt, transfer=self.transfer,
                      mass_matrix=self.mass, projection=self.projection,
                      gravity=(float(self.gravity),), damping=self.damping,
                      transfer_params=with_pic_fraction(self.transfer, self.pic_fraction,
                                                        self.transfer_params),
                      walls=walls,
                      fixed_nodes=fixed_nodes, fixed_time=self.fixed_time,
                      traction=self.traction, name=self.name,
                      displacement=self.displacement, integrator=self.integrator,
                      water=self.water, pore_water=(self.pore_water,),
                      initial_pore_pressure=self.initial_pore_pressure)
        object.__setattr__(self, "model", model)
        x, vol = model.positions[:, 0], model.volume
        object.__setattr__(self, "positions", x)
        object.__setattr__(self, "volume", vol)
        object.__setattr__(self, "velocity", model.velocity[:, 0])
        fixed = tuple(i for (i,) in model.fixed_nodes)
        object.__setattr__(self, "fixed_nodes", fixed)
        object.__setattr__(self, "walls", model.walls)
        dt = model.dt
        object.__setattr__(self, "dt", dt)
        # the stiffness a wave meets: the skeleton's, with the pore water's K_w / n where
        # the water moves with it (undrained and coupled analyses)
        stiff = self.material
        if self.water is not None and self.water.pore_pressure:
            stiff = Material(E=self.material.E + self.pore_water.storage_modulus,
                             density=self.material.density)
        if self.mass == "lumped" and basis.name == "linear":
            dt_crit = critical_time_step(self.grid.h, stiff)
        else:
            dt_crit = discrete_critical_time_step(self.grid, stiff, basis, x, vol,
                                                  self.mass, fixed)
        dt_crit *= CRITICAL_STEP_FACTOR[model.integrator]
        object.__setattr__(self, "_critical_dt", dt_crit)
        if dt_crit == 0.0 and not self.allow_unstable_dt:
            raise ValueError(
                f"the {self.mass} mass matrix assembled from these particles with the "
                f"{basis.name} basis is singular or indefinite: no time step is stable; use "
                "more particles per element, another basis or mass, or allow_unstable_dt=True")
        if dt > dt_crit and not self.allow_unstable_dt:
            rule = ("Eq. 2.4: h / sqrt(E / rho)" if self.mass == "lumped" and basis.name == "linear"
                    else "2 / w_max of the particle discretisation")
            if model.integrator != "euler-cromer":
                rule += (f", times {CRITICAL_STEP_FACTOR[model.integrator]:.4g} for "
                         f"{model.integrator}")
            raise ValueError(
                f"time step dt = {dt:g} s exceeds the critical time step {dt_crit:g} s "
                f"({rule}, h = {self.grid.h:g} m, {basis.name} basis, {self.mass} mass); "
                "choose a smaller dt or pass allow_unstable_dt=True (--allow-unstable-dt) "
                "to run anyway")

    @property
    def n_particles(self) -> int:
        return len(self.positions)

    @property
    def mass_per_particle(self) -> np.ndarray:
        return self.model.mass_per_particle

    @property
    def critical_dt(self) -> float:
        """Eq. 2.4 (lumped mass) or the element bound of the particles' consistent mass;
        times sqrt(2) under rk4 (``timpm.model.CRITICAL_STEP_FACTOR``)."""
        return self._critical_dt
