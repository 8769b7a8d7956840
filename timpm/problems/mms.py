"""Manufactured solutions in 1D, 2D and 3D: a Neo-Hookean body driven by the body force
that makes a chosen motion exact.

On the unit square (cube, segment) the displacement along each axis is

    u_i(X, t) = G sin(pi X_i) sin(c pi t + phi_i),   c = sqrt(E / rho),

phi = (0, pi, pi): the second and third components run in opposite phase.  F is diagonal,
F_ii = 1 + G pi cos(pi X_i) s_i with s_i = sin(c pi t + phi_i), and the first
Piola-Kirchhoff stress of the Neo-Hookean solid, P = mu (F - F^-T) + lambda ln J F^-T, is
diagonal too, so rho u_tt = div P + rho b gives the body force per unit mass

    b_i = -G pi^2 sin(pi X_i) s_i [c^2 - (mu (1 + F_ii^-2) + lambda (1 - ln J) F_ii^-2) / rho]

(``body_force``; tests check it against finite differences of u and P).  The normal
displacement vanishes on every side and the shear traction there is zero: the sides are
roller walls (u_n = 0 both ways, no friction; in 1D the end nodes are held).  E = 1e7 Pa,
rho = 1000 kg/m^3, nu = 0 in 1D and 0.3 in 2D and 3D, 2 particles per cell and axis (at
the Gauss points), dt = 0.2 h / c, one period t_end = 0.02 s.  G = 1e-4 is nearly linear; G = 0.05 stretches the body by 16 %, which the
linear basis' grid-crossing error does not survive (Sinaie et al. 2017).

Errors: the study's RMS displacement error sqrt(sum_p |u_p - u(X_p)|^2 / n_p) and the
volume-weighted L2 norm sqrt(sum_p V_p |u_p - u(X_p)|^2) (the body's volume is 1).
"""
import math
from dataclasses import dataclass

import numpy as np

from ..model.loads import BodyForce
from ..platform.errors import InputError
from ..materials import NeoHookean
from ..model.model import Model, Wall, with_pic_fraction
from ..model.scene import (PLACEMENTS, Material, consistent_mass_ratio,
                           discrete_critical_time_step, equidistant_particles)
from .base import Problem, ProblemScene, check_positive, lattice

__all__ = ["ManufacturedSolution", "MMS1D", "MMS2D", "MMS3D"]

#: phase of each component's time factor
PHASES = (0.0, math.pi, math.pi)


@dataclass(frozen=True)
class ManufacturedSolution(Problem):
    """See the module; ``dim`` is set by the subclasses (mms-1d, mms-2d, mms-3d)."""

    G: float = 0.05
    E: float = 1e7
    density: float = 1000.0
    nu: float | None = None  # default: 0 in 1D, 0.3 in 2D and 3D

    dim = 1
    section = "MMS"
    ppc = 2
    placement = "gauss"  # equal weights at 2 per cell: the B-splines' quadrature
    t_end = 0.02
    courant = 0.2  # dt = courant h / c

    def __post_init__(self):
        check_positive(self, "G", "E", "density")
        nu = self.poisson
        if not (-1.0 < nu < 0.5):
            raise InputError(f"{self.name}: parameter nu must lie in (-1, 0.5), got {nu!r}",
                             "nu")

    @property
    def dt_rule(self) -> str:
        return f"{self.courant:g} h / c"

    # ---- the solution ------------------------------------------------------------------
    @property
    def poisson(self) -> float:
        return (0.0 if self.dim == 1 else 0.3) if self.nu is None else float(self.nu)

    @property
    def c(self) -> float:
        """sqrt(E / rho), the speed in the solution's time factor."""
        return math.sqrt(self.E / self.density)

    @property
    def material_law(self) -> NeoHookean:
        return NeoHookean(E=self.E, nu=self.poisson, density=self.density)

    def domain_length(self):
        return 1.0

    def _time_factor(self, t, derivative=False):
        """s_i(t) = sin(c pi t + phi_i) per axis (its derivative / (c pi) if asked)."""
        phase = self.c * math.pi * float(t) + np.array(PHASES[:self.dim])
        return np.cos(phase) if derivative else np.sin(phase)

    def displacement(self, x0, t, stress_update="study"):
        """u(X, t) at reference positions X ((n,) in 1D, else (n, dim))."""
        X = self._points(x0)
        u = self.G * np.sin(np.pi * X) * self._time_factor(t)
        return u[:, 0] if np.ndim(x0) == 1 else u

    def velocity(self, x0, t):
        X = self._points(x0)
        v = self.G * self.c * np.pi * np.sin(np.pi * X) * self._time_factor(t, True)
        return v[:, 0] if np.ndim(x0) == 1 else v

    def deformation_gradient(self, X, t):
        """The diagonal of F(X, t), (n, dim)."""
        X = self._points(X)
        return 1.0 + self.G * np.pi * np.cos(np.pi * X) * self._time_factor(t)

    def first_piola(self, X, t):
        """The diagonal of P(X, t) = mu (F - F^-T) + lambda ln J F^-T, (n, dim)."""
        law = self.material_law
        F = self.deformation_gradient(X, t)
        lnJ = np.sum(np.log(F), axis=1, keepdims=True)
        return law.mu * (F - 1.0 / F) + law.lam * lnJ / F

    def body_force(self, X, t):
        """b(X, t) per unit mass that makes u exact (the module's formula), (n, dim)."""
        X = self._points(X)
        law = self.material_law
        s = self._time_factor(t)
        F = self.deformation_gradient(X, t)
        lnJ = np.sum(np.log(F), axis=1, keepdims=True)
        stiffness = (law.mu * (1.0 + F ** -2) + law.lam * (1.0 - lnJ) * F ** -2) / self.density
        return -self.G * np.pi ** 2 * np.sin(np.pi * X) * s * (self.c ** 2 - stiffness)

    def _points(self, x):
        X = np.asarray(x, dtype=float)
        return X.reshape(-1, self.dim)

    # ---- the scene ---------------------------------------------------------------------
    def scheme(self, basis, mass=None, projection=None, integrator=None, transfer="musl"):
        """With the musl transfer and a basis beyond the linear one, the internal force at
        the Gauss points (the MLS stress projection): in 1D with the consistent mass and
        the rk4 integrator, in 2D with the lumped mass and Euler-Cromer, the schemes that
        converge at order 2 and more here (docs/results.md).  Otherwise the study's: the
        linear basis' grid-crossing error sets its accuracy (and its consistent mass with
        the MLS forces breaks down at G = 0.05 from 256 elements, under either
        integrator); in 3D the MLS projection is not implemented."""
        if self.dim == 3 or transfer != "musl" or basis.support == 2:
            return super().scheme(basis, mass, projection, integrator, transfer)
        if self.dim == 2:
            return super().scheme(basis, mass, projection or "mls", integrator, transfer)
        return mass or "consistent", projection or "mls", integrator or "rk4"

    def scene(self, elements=None, ppc=None, basis="linear", mass=None, dt=None,
              placement=None, stress_update="study", allow_unstable_dt=False,
              damping=None, projection=None, transfer="musl",
              pic_fraction=None, integrator=None, transfer_params=None) -> "ProblemScene":
        """The model on ``elements`` cells per axis, ``ppc`` particles per cell and axis
        placed by ``placement`` (``timpm.model.scene.PLACEMENTS``), dt = 0.2 h / c unless given;
        mass, projection and integrator by :meth:`scheme` where not given."""
        if stress_update != "study":
            raise ValueError(f"{self.name} is a Neo-Hookean solid: it takes no stress_update "
                             f"(got {stress_update!r})")
        elements, ppc, placement, basis_cls = self.numerics(elements, ppc, placement, basis)
        mass, projection, integrator = self.scheme(basis_cls, mass, projection, integrator,
                                                   transfer)
        grid = self.grid(elements, basis_cls)  # checks the count
        n, h = grid.n_elements, grid.h
        if placement not in PLACEMENTS:
            raise ValueError(f"unknown placement {placement!r}: choose one of "
                             f"{', '.join(PLACEMENTS)}")
        X, volume = lattice((n,) * self.dim, ppc, h, placement)
        # the consistent mass in 2D/3D lowers the CFL step by sqrt(lambda_min(M_L^-1 M))
        # over the axes of the lattice (the same on every axis): a rigorous bound, the
        # Rayleigh quotient factors (scene.consistent_mass_ratio)
        mass_factor = 1.0
        if self.dim > 1 and mass == "consistent":
            x1, v1 = equidistant_particles(n, ppc, h, placement=placement)
            mass_factor = float(np.sqrt(consistent_mass_ratio(grid, basis_cls, x1, v1)
                                        ** self.dim))
        if dt is None:  # 0.2 h / c, or 0.9 of the consistent mass's critical step
            dt = min(self.courant * h / self.c,
                     0.9 * mass_factor * h / self.material_law.wave_speed)
        boundary = {}
        if self.dim == 1:
            boundary["fixed_nodes"] = tuple((i,) for i in sum(basis_cls.boundary_nodes(n), ()))
        else:
            boundary["walls"] = (Wall("roller"),) * (2 * self.dim)
        model = Model(basis=basis_cls.name, origin=(0.0,) * self.dim, h=h,
                      elements=(n,) * self.dim, positions=X, volume=volume,
                      materials=(self.material_law,), dt=dt, velocity=lambda P: self.velocity(
                          P, 0.0), transfer=transfer, mass_matrix=mass, projection=projection,
                      damping=0.0 if damping is None else damping,
                      transfer_params=with_pic_fraction(transfer, pic_fraction,
                                                        transfer_params),
                      integrator=integrator, body_force=BodyForce(self.body_force),
                      name=self.name, **boundary)
        if self.dim == 1:
            fixed = tuple(i for (i,) in model.fixed_nodes)
            critical = discrete_critical_time_step(grid, Material(self.E, self.density),
                                                   basis_cls, X[:, 0], volume, mass, fixed)
            rule = "2 / w_max of the particle discretisation"
        else:
            critical, rule = h / self.material_law.wave_speed, "the CFL limit h / c_p"
            if mass_factor < 1.0:
                critical *= mass_factor
                rule += f" times sqrt(lambda_min(M_L^-1 M)) = {mass_factor:.4g}"
        return ProblemScene(model, critical, rule, allow_unstable_dt)

    def summary(self, x0, solver, stress_update) -> dict:
        X = self._points(x0)
        error = solver.displacements().reshape(-1, self.dim) - self._points(
            self.displacement(X, solver.t))
        volume = solver.model.volume
        return {"l2_error": float(np.sqrt(np.sum(volume * np.sum(error ** 2, axis=1)))),
                "G": self.G, "dim": self.dim}

    def monitored_particle(self, x0):
        """The particle nearest the body's centre (X = 1/2 on every axis)."""
        X = self._points(x0)
        return int(np.argmin(np.sum((X - 0.5) ** 2, axis=1)))


@dataclass(frozen=True)
class MMS1D(ManufacturedSolution):
    name = "mms-1d"
    title = "Manufactured solution, 1D Neo-Hookean bar"
    dim = 1
    elements = 32


@dataclass(frozen=True)
class MMS2D(ManufacturedSolution):
    name = "mms-2d"
    title = "Manufactured solution, 2D Neo-Hookean square"
    dim = 2
    elements = 16


@dataclass(frozen=True)
class MMS3D(ManufacturedSolution):
    name = "mms-3d"
    title = "Manufactured solution, 3D Neo-Hookean cube"
    dim = 3
    elements = 8
