"""Vibrating string with fixed ends (study 3.3, Table 3.1)."""
from dataclasses import dataclass

import numpy as np

from .base import Problem, check_positive, last_below


@dataclass(frozen=True)
class VibratingString(Problem):
    """u_tt = (E/rho) u_xx, u(0) = u(L) = 0, u(x, 0) = 0, u_t(x, 0) = v0 sin(pi x / L).

    Exact solution (mode 1): u = v0 / w1 sin(w1 t) sin(pi x / L), w1 = pi sqrt(E/rho) / L.
    """

    density: float = 1.0
    E: float = 100.0
    L: float = 25.0
    v0: float = 0.1

    name = "vibrating-string"
    title = "Vibrating string (3.3)"
    section = "3.3"
    elements = 16
    ppc = 4
    dt = 1e-4
    t_end = 0.1

    def __post_init__(self):
        check_positive(self, "density", "E", "L")


    def domain_length(self):
        return self.L

    @property
    def omega(self):
        return np.pi * np.sqrt(self.E / self.density) / self.L

    def conditions(self, x0, basis, grid):
        return dict(velocity=self.v0 * np.sin(np.pi * x0 / self.L),
                    fixed_nodes=sum(basis.boundary_nodes(grid.n_elements), ()))

    def displacement(self, x0, t, stress_update="study"):
        return self.v0 / self.omega * np.sin(self.omega * t) * np.sin(np.pi * np.asarray(x0) / self.L)

    def velocity(self, x0, t):
        return self.v0 * np.cos(self.omega * t) * np.sin(np.pi * np.asarray(x0) / self.L)

    def monitored_particle(self, x0):
        # "the particle situated directly left of the middle of the string" (Fig. 3.3)
        return last_below(x0, 0.5 * self.L)

