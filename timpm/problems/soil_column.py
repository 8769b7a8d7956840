"""Soil column under self-weight (study 3.4, Table 3.3) and its large-deformation
variant (A.5, Table A.1)."""
from dataclasses import dataclass

import numpy as np

from ..model.scene import Constant, Traction
from ..platform.checks import whole
from ..platform.errors import InputError
from .base import Problem, ProblemScene, check_positive, last_below, lattice

#: the most terms of the series solution (default 4000): every evaluation sums them all
MAX_TERMS = 10 ** 6


@dataclass(frozen=True)
class SoilColumn(Problem):
    """u_tt = (E/rho) u_yy - g, u(0) = 0, u_y(H) = p0/E, u(y, 0) = u_t(y, 0) = 0.

    ``gravity`` is the signed physical acceleration along y (-9.81: downwards, as in
    Table 3.3).  The study's series solution is written for the PDE above with g the
    *magnitude* of gravity: inserting g = -9.81 literally would lift the column.  So the
    exact solution here uses g = -gravity = 9.81, which compresses the column as gravity
    does (static tip displacement -rho g H^2 / (2E)).
    """

    density: float = 1.0
    E: float = 5e4
    gravity: float = -9.81
    H: float = 25.0
    p0: float = 0.0
    n_terms: int = 4000

    name = "soil-column"
    title = "Soil column under self-weight (3.4)"
    section = "3.4"
    elements = 40
    ppc = 2
    dt = 1e-3
    t_end = 1.0
    free_end = True

    def __post_init__(self):
        check_positive(self, "density", "E", "H")
        n_terms = whole(f"{self.name}: parameter n_terms", self.n_terms)
        if n_terms > MAX_TERMS:
            raise InputError(f"{self.name}: parameter n_terms must be at most {MAX_TERMS} (every "
                             f"evaluation of the series sums them all), got {self.n_terms!r}",
                             "n_terms")
        object.__setattr__(self, "n_terms", n_terms)

    def domain_length(self):
        return self.H

    def conditions(self, x0, basis, grid):
        kw = dict(gravity=self.gravity, fixed_nodes=basis.boundary_nodes(grid.n_elements)[0])
        if self.p0 != 0.0:
            kw["traction"] = Traction(int(np.argmax(x0)), self.p0, Constant())
        return kw

    def _modes(self):
        g = -self.gravity
        n = np.arange(1, self.n_terms + 1, dtype=float)
        sign = (-1.0) ** n
        un = (8 * self.H * (2 * np.pi * self.p0 * n * sign + 2 * self.density * g * self.H
                            - np.pi * self.p0 * sign)
              / ((4 * n ** 2 - 4 * n + 1) * (2 * n - 1) * np.pi ** 3 * self.E))
        k = (2 * n - 1) * np.pi / (2 * self.H)
        return g, un, k, np.sqrt(self.E / self.density) * k

    def displacement(self, x0, t, stress_update="study"):
        g, un, k, w = self._modes()
        y = np.asarray(x0, dtype=float)
        static = 0.5 * self.density * g * y ** 2 / self.E + (self.p0 - self.density * g * self.H) * y / self.E
        return static + _series(y, un * np.cos(w * t), k)

    def velocity(self, x0, t):
        g, un, k, w = self._modes()
        return _series(np.asarray(x0, dtype=float), -un * w * np.sin(w * t), k)

    def monitored_particle(self, x0):
        # "the particle situated just beneath the middle of the column" (Figs. 3.7-3.10)
        return last_below(x0, 0.5 * self.H)


def _series(y, coeff, k, chunk=256):
    """sum_n coeff_n sin(k_n y), in chunks of points to bound memory."""
    out = np.empty_like(y)
    flat, res = y.ravel(), out.ravel()
    for s in range(0, len(flat), chunk):
        res[s:s + chunk] = np.sin(np.outer(flat[s:s + chunk], k)) @ coeff
    return out


@dataclass(frozen=True)
class LargeColumn(SoilColumn):
    """The large-deformation column of A.5 (Table A.1): no closed-form solution; the
    study compares MPM (30 elements, 50 particles per element) with updated-Lagrangian FEM."""

    density: float = 1e3
    E: float = 1e5
    H: float = 1.0

    name = "large-column"
    title = "Large-deformation soil column (A.5)"
    section = "A.5"
    elements = 30
    ppc = 50
    dt = 1e-3
    t_end = 3.0
    has_exact = False

    def displacement(self, x0, t, stress_update="study"):
        raise NotImplementedError("the large-deformation column has no exact solution "
                                  "(the study uses updated-Lagrangian FEM as reference)")

    def velocity(self, x0, t):
        return self.displacement(x0, t)


@dataclass(frozen=True)
class SoilColumn2D(SoilColumn):
    """The soil column of 3.4 in plane strain: ``width`` cells wide between slip walls, a
    sticky floor, gravity along -y, linear elastic with nu = 0, so that no lateral stress
    arises and the 1D series is the exact u_y (u_x = 0).  Particles per cell and axis as
    in 1D (``placement``); the grid reaches beyond the free top."""

    width: int = 4

    name = "soil-column-2d"
    title = "Soil column under self-weight, plane strain (3.4 in 2D)"
    section = "3.4"
    elements = 40
    dim = 2

    def cells(self, elements):
        return (self.width, elements)

    def __post_init__(self):
        super().__post_init__()
        try:
            object.__setattr__(self, "width", whole("width", self.width))
        except ValueError:
            raise InputError(f"{self.name}: width must be a positive number of cells, got "
                             f"{self.width!r}", "width") from None
        if self.p0 != 0.0:
            raise ValueError(f"{self.name}: the top load p0 acts in 1D only (soil-column)")

    def scene(self, elements=None, ppc=None, basis="linear", mass=None, dt=None,
              placement=None, stress_update="study", allow_unstable_dt=False,
              damping=None, projection=None, transfer="musl", pic_fraction=None,
              integrator=None, transfer_params=None):
        from ..materials import LinearElastic
        from ..model.model import Model, Wall, with_pic_fraction

        if stress_update != "study":
            raise ValueError(f"{self.name} is linear elastic (nu = 0): it takes no "
                             f"stress_update (got {stress_update!r})")
        elements, ppc, placement, basis_cls = self.numerics(elements, ppc, placement, basis)
        mass, projection, integrator = self.scheme(basis_cls, mass, projection, integrator,
                                                   transfer)
        dt = self.dt if dt is None else dt
        self.grid(elements, basis_cls)  # checks the count
        n, h = int(elements), self.H / elements
        # padding: the uniform splines' stencils reach beyond the walls; every basis needs
        # room above the free top
        side = basis_cls.support if basis_cls.uniform_nodes and basis_cls.name != "linear" else 0
        top = max(side, max(1, basis_cls.support - 1))
        X, volume = lattice((self.width, n), ppc, h, placement)
        model = Model(basis=basis_cls.name, origin=(-side * h, -side * h), h=h,
                      elements=(self.width + 2 * side, n + side + top),
                      positions=X, volume=volume,
                      materials=(LinearElastic(self.E, 0.0, self.density),), dt=dt,
                      transfer=transfer, mass_matrix=mass, projection=projection,
                      gravity=(0.0, self.gravity), damping=0.0 if damping is None else damping,
                      transfer_params=with_pic_fraction(transfer, pic_fraction,
                                                        transfer_params),
                      integrator=integrator,
                      walls=(Wall("slip"), Wall("slip"), Wall("sticky"), None),
                      wall_cells=((side, side + self.width), (side, side + n + top)),
                      name=self.name)
        return ProblemScene(model, h / np.sqrt(self.E / self.density), "h / c",
                            allow_unstable_dt)

    def displacement(self, x0, t, stress_update="study"):
        X = np.asarray(x0, dtype=float).reshape(-1, 2)
        u = np.zeros_like(X)
        u[:, 1] = super().displacement(X[:, 1], t)
        return u

    def velocity(self, x0, t):
        X = np.asarray(x0, dtype=float).reshape(-1, 2)
        v = np.zeros_like(X)
        v[:, 1] = super().velocity(X[:, 1], t)
        return v

    def monitored_particle(self, x0):
        X = np.asarray(x0, dtype=float).reshape(-1, 2)
        return int(np.argmin((X[:, 0] - X[:, 0].mean()) ** 2 + (X[:, 1] - 0.5 * self.H) ** 2))
