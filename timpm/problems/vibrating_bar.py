"""Vibrating bar with dynamic traction at its free end (study 3.5, Table 3.4)."""
from dataclasses import dataclass

import numpy as np

from ..model.scene import Sine, Traction
from .base import Problem, check_positive


@dataclass(frozen=True)
class VibratingBar(Problem):
    """u_tt = (E/rho) u_xx, u(0) = 0, a traction tau sin(pi t / L) on the free end x = L.

    The exact solution of Bardenhagen & Kober (the study's [9]) holds for a wave speed
    sqrt(E/rho) = 1, as in Table 3.4.  The load acts on the particle at the end of the
    bar; the grid extends beyond L so the loaded end stays inside it.
    """

    density: float = 100.0
    E: float = 100.0
    L: float = 1.0
    tau: float = 1.0

    name = "vibrating-bar"
    title = "Vibrating bar with dynamic traction (3.5)"
    section = "3.5"
    elements = 16
    ppc = 3
    dt = 1e-3
    t_end = 1.0
    free_end = True

    def __post_init__(self):
        check_positive(self, "density", "E", "L")
        if not np.isclose(self.E, self.density):
            raise ValueError(f"the exact solution of the vibrating bar needs wave speed 1 "
                             f"(E = rho), got E = {self.E}, rho = {self.density}")


    def domain_length(self):
        return self.L

    def conditions(self, x0, basis, grid):
        return dict(fixed_nodes=basis.boundary_nodes(grid.n_elements)[0],
                    traction=Traction(int(np.argmax(x0)), self.tau, Sine(np.pi / self.L)))

    def _phases(self, x0, t):
        """x, t and the conditions of the solution's five phases (wave not yet arrived,
        arriving, reflected, leaving, gone): t in [0, L-x], [L-x, L+x], [L+x, 3L-x], ..."""
        L = self.L
        x = np.asarray(x0, dtype=float)
        t = np.broadcast_to(np.asarray(t, dtype=float), x.shape)
        return x, t, [t <= L - x, t <= L + x, t <= 3 * L - x, t <= 3 * L + x]

    def displacement(self, x0, t, stress_update="study"):
        x, t, phases = self._phases(x0, t)
        w, alpha = np.pi / self.L, self.L * self.tau / (self.density * np.pi)
        return np.select(phases, [0.0 * x, alpha * (1 + np.cos(w * (t + x))),
                                  alpha * (np.cos(w * (t + x)) - np.cos(w * (t - x))),
                                  alpha * (-1 - np.cos(w * (t - x)))], 0.0 * x)

    def velocity(self, x0, t):
        x, t, phases = self._phases(x0, t)
        w, alpha = np.pi / self.L, self.L * self.tau / (self.density * np.pi)
        return np.select(phases, [0.0 * x, -alpha * w * np.sin(w * (t + x)),
                                  -alpha * w * (np.sin(w * (t + x)) - np.sin(w * (t - x))),
                                  alpha * w * np.sin(w * (t - x))], 0.0 * x)

    def monitored_particle(self, x0):
        return int(np.argmax(x0))  # the loaded end
