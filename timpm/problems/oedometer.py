"""Loaded oedometer column brought to equilibrium with local damping (study A.4)."""
from dataclasses import dataclass

import numpy as np

from ..model.scene import Constant, Ramp, Traction
from ..platform.errors import InputError
from .base import Problem, check_positive


@dataclass(frozen=True)
class Oedometer(Problem):
    """A column fixed at its base, no gravity, a compressive load p0 on its top particle.

    Damped to rest (alpha of A.4), the strain is -p0/E with the small-strain stress update
    and -ln(1 + p0/E) with the study's update sigma += (E - sigma) d_eps.  ``displacement``
    gives the static solution of the chosen update, uniform strain below the load.  The
    strain is measured as the study does, from the displacement of the point at mid-height:
    Delta H / H (small) or ln(1 + Delta H / H) (large).

    The particle velocity update blends in 1% PIC (``pic_fraction``): with the study's
    FLIP update alone, 640 particles on 11 nodes keep velocities of -0.21 to +0.35 m/s at
    rest (a mode the grid cannot see, which local damping on grid forces never reaches);
    with 1% PIC they are below 1e-10 m/s at t = 6 s and the strain error falls from 0.074%
    to 0.040% (``benchmarks/oedometer_pic.py``, 2026-11-24; 20-100% PIC settles slower).

    The load is ramped over ``ramp`` seconds (0: a step load).  Many particles per element
    are the default: once the column is compressed, particles cross elements and an element
    holds a varying particle volume; the internal force then carries a quadrature error
    (study 2.3.2) of order one particle volume per element, so the equilibrium strain is
    within 1% of ln(1 + p0/E) only with some tens of particles per element.
    """

    density: float = 1e3
    E: float = 1e5
    H: float = 1.0
    p0: float = 5e4
    alpha: float = 0.7
    ramp: float = 1.0

    name = "oedometer"
    title = "Loaded oedometer column (A.4)"
    section = "A.4"
    elements = 10
    ppc = 64
    dt = 1e-3
    t_end = 6.0
    free_end = True
    pic_fraction = 0.01

    def __post_init__(self):
        check_positive(self, "density", "E", "H")
        if self.p0 < 0 or not np.isfinite(self.p0):
            raise InputError(f"{self.name}: parameter p0 must be a non-negative (compressive) "
                             f"load, got {self.p0!r}", "p0")
        if not (np.isfinite(self.ramp) and self.ramp >= 0):
            raise InputError(f"{self.name}: parameter ramp must be a duration >= 0 (0: a step "
                             f"load), got {self.ramp!r}", "ramp")


    def domain_length(self):
        return self.H

    def conditions(self, x0, basis, grid):
        return dict(fixed_nodes=basis.boundary_nodes(grid.n_elements)[0],
                    traction=Traction(int(np.argmax(x0)), -self.p0,
                                     Ramp(self.ramp) if self.ramp > 0 else Constant()),
                    damping=self.alpha)

    def strain(self, stress_update="study"):
        """Equilibrium strain of the column under p0: logarithmic, except the engineering
        strain of the forward-Euler small-strain update; E ln F = -p0 with ``small-exact``."""
        if stress_update in ("small", "small-exact"):
            return -self.p0 / self.E
        return -np.log1p(self.p0 / self.E)

    def displacement(self, x0, t, stress_update="study"):
        # the stretch is uniform below the load: u = (stretch - 1) y
        eps = self.strain(stress_update)
        stretch = 1.0 + eps if stress_update == "small" else np.exp(eps)
        return (stretch - 1.0) * np.asarray(x0, dtype=float)

    def summary(self, x0, solver, stress_update):
        """Strain at the particle nearest mid-height against the equilibrium strain."""
        p = self.monitored_particle(x0)
        stretch = 1.0 + solver.displacements()[p] / x0[p]
        strain = float(stretch - 1.0 if stress_update == "small" else np.log(stretch))
        exact = float(self.strain(stress_update))
        return {"strain": strain, "exact_strain": exact,
                "strain_relative_error": abs(strain - exact) / abs(exact) if exact else None}

    def velocity(self, x0, t):
        return np.zeros_like(np.asarray(x0, dtype=float))
