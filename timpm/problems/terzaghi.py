"""Terzaghi's one-dimensional consolidation: a saturated layer under a sudden load.

A layer of height H on an impermeable, fixed base, drained at its top where the load p0
acts, no gravity.  At t = 0 the water carries the whole load (an excess pore pressure
u0 = p0, the skeleton unstressed); it then drains through the top.  The excess pore
pressure solves c_v u_zz = u_t with c_v = k / (gamma_w (1 / E_oed + n / K_w)) (the water's
compressibility in the storage), u(Z, 0) = u0 and u = 0 at the drained top:

    u / u0 = sum_m (2 / M) sin(M Z) exp(-M^2 T),  M = (2m + 1) pi / 2,

Z the depth below the top over the drainage length H, T = c_v t / H^2 the time factor.  The
total stress stays -p0, so sigma' = -(p0 - u) and the strain is sigma' / E_oed: the
displacement of a point at height x above the base is

    u_x = -(p0 / E_oed) [x - H sum_m (2 / M^2) cos(M Z) exp(-M^2 T)],

and the degree of consolidation, the settlement over its final value, is U = 1 - sum_m
(2 / M^2) exp(-M^2 T) (0.357, 0.504, 0.764, 0.931 at T = 0.1, 0.2, 0.5, 1).

``drainage="both"``: the base drains too (``Water(drained_sides=("left",))``: its
Dirichlet node holds the skeleton, not the water).  The drainage length is then H_d = H /
2, Z the distance from the nearer face over H_d, T = c_v t / H_d^2: the same series on each
half, and below the mid-plane u_x = -(p0 / E_oed) [x - H_d sum (2 / M^2) (1 - cos(M Z))
exp(-M^2 T)], above it with 1 + cos(M Z).  The run is the
coupled two-phase MUSL step (schemes/two_phase.py; ``Water(analysis="coupled")``): the
water flows, Darcy's drag couples it to the skeleton, and the load is carried over from the
water to the soil as it drains.  The solution is quasi-static; the run is dynamic, its time
step the undrained wave's, sqrt((E_oed + K_w / n) / rho) (the waves' share of the answer is
small: t_c = H^2 / c_v is 10^5 wave crossings at the defaults).
"""
import math
from dataclasses import dataclass

import numpy as np

from ..materials.pore_water import STANDARD_GRAVITY, PoreWater
from ..model.scene import Constant, Material, Traction
from ..model.water import Water
from .base import Problem, check_positive

__all__ = ["Terzaghi", "consolidation_series", "degree_of_consolidation"]

#: terms of the series: the slowest neglected term is below 1e-12 of u0 for T >= 1e-4
TERMS = 400
#: the faces the water leaves by: the top (the base impermeable), or the top and the base
DRAINAGE = ("top", "both")
#: the monitored depths Z = depth / H_d (1: the undrained base, or the mid-plane)
DEPTHS = (0.25, 0.5, 0.75, 1.0)


def _modes():
    return math.pi * (2 * np.arange(TERMS) + 1) / 2.0


def consolidation_series(Z, T):
    """u / u0 at depths ``Z`` (below the drained top, over the drainage length) and time
    factor ``T``."""
    M = _modes()
    Z = np.asarray(Z, dtype=float)
    return np.sum((2.0 / M) * np.sin(np.multiply.outer(Z, M)) * np.exp(-M * M * T), axis=-1)


def degree_of_consolidation(T) -> float:
    """U(T) = 1 - sum (2 / M^2) exp(-M^2 T): the settlement over the final settlement."""
    M = _modes()
    return float(1.0 - np.sum(2.0 / M ** 2 * np.exp(-M * M * T)))


@dataclass(frozen=True)
class Terzaghi(Problem):
    """See the module: E the constrained modulus E_oed of the skeleton, density its
    saturated density, H the layer (the drainage length), p0 the load, porosity n,
    conductivity k (m/s), water_modulus K_w, water_density rho_w; ``time_factor`` T of the
    default end time t = T H^2 / c_v."""

    E: float = 1.0e6
    density: float = 2000.0
    H: float = 1.0
    p0: float = 1.0e3
    porosity: float = 0.4
    conductivity: float = 1.0e-3
    water_modulus: float = 2.2e9
    water_density: float = 1000.0
    time_factor: float = 1.0
    drainage: str = "top"

    name = "terzaghi"
    title = "Terzaghi's one-dimensional consolidation"
    section = ""
    elements = 16
    ppc = 4
    courant = 0.4  # dt = courant h / c_u, c_u the undrained wave speed

    def __post_init__(self):
        check_positive(self, "E", "density", "H", "p0", "conductivity", "water_modulus",
                       "water_density", "time_factor")
        self.pore_water  # the water's own checks (porosity in (0, 1))
        if self.drainage not in DRAINAGE:
            raise ValueError(f"terzaghi: drainage must be one of {', '.join(DRAINAGE)} (the "
                             f"faces the water leaves by), got {self.drainage!r}")

    @property
    def drainage_length(self) -> float:
        """H_d: the layer drained at its top (H), or at its top and base (H / 2)."""
        return self.H if self.drainage == "top" else 0.5 * self.H

    @property
    def pore_water(self) -> PoreWater:
        return PoreWater(porosity=self.porosity, conductivity=self.conductivity,
                         density=self.water_density, bulk_modulus=self.water_modulus)

    @property
    def material(self) -> Material:
        """The skeleton: linear elastic, small strain (Terzaghi's)."""
        return Material(self.E, self.density, stress_update="small")

    @property
    def c_v(self) -> float:
        """The coefficient of consolidation k / (gamma_w (1 / E_oed + n / K_w)), m^2/s."""
        gamma_w = self.water_density * STANDARD_GRAVITY
        return self.conductivity / (gamma_w * (1.0 / self.E + self.porosity / self.water_modulus))

    @property
    def undrained_wave_speed(self) -> float:
        return self.pore_water.undrained_wave_speed(self.E, self.density)

    @property
    def explicit_drag_time_step(self) -> float:
        """2 / a, a = n rho_sat g / ((1 - n) rho_s k): the step an explicit drag would need
        (Anura3D's bound; the two-phase step takes the drag implicitly and is not bound by
        it)."""
        n = self.porosity
        rho_s = (self.density - n * self.water_density) / (1.0 - n)
        return 2.0 * (1.0 - n) * rho_s * self.conductivity / (n * self.density * STANDARD_GRAVITY)

    @property
    def t_end(self) -> float:
        return self.time_factor * self.drainage_length ** 2 / self.c_v

    @property
    def dt_rule(self) -> str:
        return f"{self.courant:g} h / c_u"

    def time_factor_at(self, t) -> float:
        return self.c_v * t / self.drainage_length ** 2

    def domain_length(self):
        return self.H

    def scene(self, elements=None, ppc=None, basis="linear", mass=None, dt=None, **options):
        """The layer's scene (the base's options); dt = 0.4 h / c_u unless given."""
        if dt is None:
            n = self.elements if elements is None else elements
            if isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n > 0:
                dt = self.courant * self.H / n / self.undrained_wave_speed
        return super().scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=dt,
                             **options)

    def conditions(self, x0, basis, grid):
        n = len(x0)
        sides = () if self.drainage == "top" else ("left",)  # (1D: the base at x = 0)
        return dict(fixed_nodes=basis.boundary_nodes(grid.n_elements)[0],
                    traction=Traction(int(np.argmax(x0)), -self.p0, Constant()),
                    pore_water=self.pore_water, water=Water("coupled", drained_sides=sides),
                    initial_pore_pressure=np.full(n, self.p0))

    def depth(self, x):
        """Z: the distance from the nearest drained face over the drainage length."""
        x = np.asarray(x, dtype=float)
        if self.drainage == "both":
            return np.minimum(x, self.H - x) / self.drainage_length
        return (self.H - x) / self.H

    def pore_pressure(self, x0, t):
        """The exact excess pore pressure at heights ``x0`` and time ``t``."""
        return self.p0 * consolidation_series(self.depth(x0), self.time_factor_at(t))

    def displacement(self, x0, t, stress_update="study"):
        x = np.asarray(x0, dtype=float)
        M = _modes()
        T = self.time_factor_at(t)
        Z = self.depth(x)
        cos = np.cos(np.multiply.outer(Z, M))
        if self.drainage == "both":
            # int_0^x u dx' / u0: below the mid-plane (2 H_d / M^2)(1 - cos(M Z)), above it
            # the lower half's 2 H_d / M^2 plus (2 H_d / M^2) cos(M Z) (cos M = 0)
            lower = (x <= 0.5 * self.H)[..., None]
            cos = np.where(lower, 1.0 - cos, 1.0 + cos)
        s = np.sum(2.0 / M ** 2 * cos * np.exp(-M * M * T), axis=-1)
        return -(self.p0 / self.E) * (x - self.drainage_length * s)

    def velocity(self, x0, t):
        x = np.asarray(x0, dtype=float)
        M = _modes()
        T = self.time_factor_at(t)
        dTdt = self.c_v / self.drainage_length ** 2
        cos = np.cos(np.multiply.outer(self.depth(x), M))
        if self.drainage == "both":
            cos = np.where((x <= 0.5 * self.H)[..., None], 1.0 - cos, 1.0 + cos)
        s = np.sum(-2.0 * cos * np.exp(-M * M * T), axis=-1)
        return -(self.p0 / self.E) * (-self.drainage_length * s * dTdt)

    def monitored_particle(self, x0) -> int:
        return int(np.argmax(np.asarray(x0)))  # the top: the settlement

    def summary(self, x0, solver, stress_update) -> dict:
        """u / u0 at the monitored depths against the series, by linear interpolation
        between the particles' current positions; the average degree of consolidation
        against the series; the RMS error of the pore pressure over the particles, relative
        to u0.  (The settlement of the top particle lags the series' by about 1% of the
        final one: the study's particle traction loads the top element at its top
        particle, not at its face, and the element carries that share of the load.)"""
        t = solver.t
        T = self.time_factor_at(t)
        x = solver.read("x")[:, 0]
        pw = solver.read("pw")
        order = np.argsort(x)
        depths = np.array(DEPTHS)
        # below the top (both faces drained: down to the mid-plane, Z = 1; one: to the
        # base, where np.interp takes the lowest particle's value)
        heights = self.H - self.drainage_length * depths
        numerical = np.interp(heights, x[order], pw[order]) / self.p0
        exact = consolidation_series(depths, T)
        vol = solver.read("vol")
        return {"time_factor": T, "c_v": self.c_v, "monitored_depths": list(DEPTHS),
                "u_over_u0": [float(v) for v in numerical],
                "u_over_u0_exact": [float(v) for v in exact],
                "u_over_u0_max_error": float(np.max(np.abs(numerical - exact))),
                # the average degree of consolidation, 1 - int u dz / (u0 H) (the settlement
                # over its final value): the particles' quadrature of the excess pressure
                "degree_of_consolidation": float(1.0 - np.sum(pw * vol) / (self.p0 * np.sum(vol))),
                "degree_of_consolidation_exact": degree_of_consolidation(T),
                "pore_pressure_rms_error": float(np.sqrt(np.mean(
                    (pw - self.pore_pressure(x0, t)) ** 2)) / self.p0),
                "undrained_wave_speed": self.undrained_wave_speed,
                "explicit_drag_time_step": self.explicit_drag_time_step}
