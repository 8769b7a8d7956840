"""Demo scenes, each checked against an experiment or a conservation law, rendered to GIF.

* ``column-collapse``: a granular column (Drucker-Prager sand) released against a wall onto
  a rough floor; the run-out (L_inf - L0) / L0 against the aspect ratio a = H0 / L0 follows
  the 2D experiments of Lube et al. (2005): 1.2 a for small a, 1.9 a^(2/3) for tall columns.
* ``disks``: two elastic disks colliding head-on (Sulsky et al. 1994): kinetic, strain and
  total energy through the collision.
* ``slope``: Griffiths & Lane's slope with its strength reduced past its factor of
  safety: it fails along a band of plastic strain and runs out.
* ``dam-break``: a water column of width a and height 2a (n^2 = 2) collapsing onto a dry
  floor; the surge front x / a against t sqrt(2 g / a) is Martin & Moyce's (1952) data.
* ``submarine-slope``: the slope under the sea, of a weaker saturated soil, failing
  undrained and running out under water, coloured by its excess pore pressure.

``run_demo(name, movie=Movie("scene.gif"))`` builds the scene, runs it frame by frame and
hands every frame to the movie (:class:`timpm.output.render.Movie` rasterises it in a
Taichi kernel and writes the GIF); simulation and rendering times are reported apart.
The colours' range is fixed for the whole run, from the scene's physics
(:func:`color_range`).
Each demo's ``observe`` collects its diagnostic series per frame.  The plots of the
diagnostics are :func:`timpm.output.viz.plot_demo` and :func:`timpm.output.viz.plot_runout`.
"""

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..materials import DruckerPrager, NeoHookean, WeaklyCompressibleFluid
from ..platform.progress import Progress
from ..platform.checks import positive as _positive, step_count, whole
from ..simulation.solver import Solver
from ..model.world import Ball, Body, Box, Wall, World

__all__ = ["DEMOS", "get_demo", "run_demo", "run_frames", "DemoResult", "ColumnCollapse", "Disks",
           "DamBreak", "SlopeFailure", "SubmarineSlope", "QUANTITIES", "color_range", "lube_runout", "lajeunesse_runout",
           "MARTIN_MOYCE_N2_2"]

#: colour quantities
QUANTITIES = ("speed", "pressure", "plastic", "von-mises", "body", "pore-pressure")
G = 9.81  # gravity [m/s^2]

#: Martin & Moyce (1952), column height 2a (n^2 = 2), surge front Z = x / a against
#: T = t sqrt(2 g / a); their Tables 2 and 6 (a = 2.25 in) as transcribed in Ocellaris'
#: scripts/plot_dam_break.py (TormodLandet/Ocellaris @ e338249f) and, for T <= 2.98, in
#: Lethe's dam-break-2d.py (chaos-polymtl/lethe @ 8c1580cf)
MARTIN_MOYCE_N2_2 = np.array([
    (0.41, 1.11), (0.84, 1.22), (1.19, 1.44), (1.43, 1.67), (1.63, 1.89), (1.83, 2.11),
    (1.98, 2.33), (2.20, 2.56), (2.32, 2.78), (2.51, 3.00), (2.65, 3.22), (2.83, 3.44),
    (2.98, 3.67), (3.11, 3.89), (3.33, 4.11)])


def lube_runout(a):
    """Run-out (L_inf - L0) / L0 of a 2D granular column of aspect ratio a (Lube et al.
    2005, as quoted by Lagree, Staron & Popinet 2011, Eq. 3.1): 1.2 a below the
    transition (a ~ 1.8-2.8), 1.9 a^(2/3) above; here the smaller of the two, which
    switches at a = (1.9 / 1.2)^3 ~ 3.97."""
    a = np.asarray(a, dtype=float)
    return np.minimum(1.2 * a, 1.9 * a ** (2.0 / 3.0))


def lajeunesse_runout(a):
    """Run-out of Lajeunesse et al.'s (2005) quasi-2D experiments, from the same table of
    Lagree, Staron & Popinet (2011, Eq. 3.1): 1.8 a below a ~ 3, 2.3 a^(2/3) above."""
    a = np.asarray(a, dtype=float)
    return np.where(a < 3.0, 1.8 * a, 2.3 * a ** (2.0 / 3.0))


@dataclass
class Demo:
    """A scene with a default length of run, colour and per-frame diagnostics."""

    name = ""
    color = "speed"
    #: the run records its energies (a demo whose summary or plot reads them): a record
    #: every ~1/200 of the run, each a launch, that also cuts the team's launches short
    records_energies = False
    t_end: float | None = None
    transfer: str = "mls-mpm"
    basis: str = "uniform-bspline2"
    #: the transfer scheme's parameters (timpm.schemes; None: its defaults)
    transfer_params: dict | None = None

    def __post_init__(self):
        # counts (cells, particles per cell, dim) are whole numbers: 34.0 from a command
        # line is 34, 2.5 or 0 is refused
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.type in (int, "int") or (f.type in ("int | None", int | None)
                                          and value is not None):
                setattr(self, f.name, whole(f"{self.name}: {f.name}", value))

    def world(self) -> World:
        raise NotImplementedError

    def default_t_end(self) -> float:
        raise NotImplementedError

    def observe(self, solver, t) -> dict:
        return {}

    def summary(self, solver, series) -> dict:
        return {}

    def speed_scale(self) -> float:
        """The scene's speed scale [m/s]: the top of the speed colour bar."""
        raise NotImplementedError

    def stress_scale(self) -> float:
        """The scene's stress scale [Pa]: the top of the pressure and von Mises bars."""
        raise NotImplementedError

    def strain_scale(self) -> float:
        """The top of the plastic strain colour bar: 10, so that the core that does not
        flow stays dark and the strain shows growing along the flow (the shear layer on
        the floor, 30 and more, takes the top colour)."""
        return 10.0

    def title(self) -> str:
        """The scene's name as the movie's frames show it."""
        return self.name

    def pore_pressure_scale(self) -> float:
        """The top of the excess pore pressure's colour bar (its bottom: minus it)."""
        raise ValueError(f"the {self.name} demo has no pore water")

    def end_time(self):
        return self.default_t_end() if self.t_end is None else _positive("t_end", self.t_end)


@dataclass
class ColumnCollapse(Demo):
    """Sand column of width ``width`` and height ``aspect * width`` against the left wall,
    released onto a floor with Coulomb friction ``floor_friction``."""

    name = "column-collapse"
    color = "plastic"
    aspect: float = 2.0
    width: float = 0.5
    # 23 cells across the column, 3x3 particles a cell: 9,522 particles, in real time on
    # two cores (1.16-1.26 simulated s per wall s, 2026-11-27), the run-out 0.2% from
    # Lajeunesse's fit; 34 cells (20,808 particles) ran at 0.35 and 2.1% (docs/results.md)
    cells_per_width: int = 23
    ppc: int = 3
    E: float = 4e5
    nu: float = 0.3
    density: float = 1500.0
    friction_angle: float = 30.0
    floor_friction: float = 0.58  # tan(30 deg): a floor as rough as the sand itself
    front_thickness: float = 0.02  # the front is where the deposit thins below this x H0
    courant: float = 0.8

    def world(self) -> World:
        a = _positive("aspect", self.aspect)
        L0 = _positive("width", self.width)
        h = L0 / self.cells_per_width
        est = float(lube_runout(a))
        nx = int(math.ceil(L0 * (2.0 + 2.0 * est) / h))
        ny = int(math.ceil(a * L0 * 1.05 / h)) + 2
        sand = DruckerPrager(E=self.E, nu=self.nu, density=self.density,
                             friction_angle=self.friction_angle)
        return World(domain=(nx * h, ny * h), cells=nx, basis=self.basis, transfer=self.transfer,
                     transfer_params=self.transfer_params,
                     bodies=[Body(Box((0.0, 0.0), (L0, a * L0)), sand, ppc=self.ppc, name="sand")],
                     walls={"default": "slip", "bottom": Wall("friction", self.floor_friction)},
                     courant=self.courant, name=self.name)

    def default_t_end(self) -> float:
        # the collapse is over after a few free-fall times of the column
        return 4.0 * math.sqrt(self.aspect * self.width / 9.81) + 0.3

    def speed_scale(self) -> float:
        """sqrt(2 g H0): the speed of a free fall from the column's top."""
        return math.sqrt(2.0 * G * self.aspect * self.width)

    def stress_scale(self) -> float:
        """rho g H0: the weight of the column on its base."""
        return self.density * G * self.aspect * self.width

    def observe(self, solver, t) -> dict:
        x = solver.positions()
        return {"front": self.front(x, solver.h), "tip": float(x[:, 0].max()),
                "height": float(x[:, 1].max()),
                "kinetic": float(0.5 * np.sum(solver.scene.mass_per_particle
                                              * np.sum(solver.velocities() ** 2, axis=1)))}

    def title(self) -> str:
        return f"column collapse, a = {self.aspect:g}"

    def front(self, x, h):
        """Farthest x at which the deposit is at least ``front_thickness`` H0 thick (columns
        of width h); the tip, the farthest particle, belongs to a layer a grain thick."""
        cols = np.floor(x[:, 0] / h).astype(int)
        top = np.zeros(cols.max() + 1)
        np.maximum.at(top, cols, x[:, 1])
        thick = np.flatnonzero(top >= self.front_thickness * self.aspect * self.width)
        return float((thick.max() + 1) * h) if len(thick) else 0.0

    def summary(self, solver, series) -> dict:
        L0 = self.width
        runout = (series["front"][-1] - L0) / L0
        law = float(lube_runout(self.aspect))
        ke = np.asarray(series["kinetic"])
        other = float(lajeunesse_runout(self.aspect))
        return {"aspect": self.aspect, "width": L0, "runout": runout, "lube_runout": law,
                "relative_error": (runout - law) / law, "lajeunesse_runout": other,
                "lajeunesse_relative_error": (runout - other) / other,
                "tip_runout": (series["tip"][-1] - L0) / L0,
                "final_height": series["height"][-1] / L0,
                "settled": bool(ke[-1] < 1e-3 * ke.max()) if ke.max() > 0 else True}


@dataclass
class Disks(Demo):
    """Two elastic disks (balls in 3D) colliding head-on along the diagonal (Sulsky et al.
    1994: E = 1000 Pa, nu = 0.3, rho = 1000 kg/m^3, R = 0.2 m, |v| = 0.1 sqrt(2) m/s).
    ``cells`` along each axis: by default 128 in 2D and ``CELLS_3D`` in 3D."""

    name = "disks"
    color = "von-mises"
    records_energies = True  # the energy balance of the collision (Sulsky et al.)
    CELLS_2D, CELLS_3D = 128, 40
    transfer: str = "apic"
    cells: int | None = None
    ppc: int = 2
    dim: int = 2
    E: float = 1000.0
    nu: float = 0.3
    density: float = 1000.0
    speed: float = 0.1
    courant: float = 0.4

    def world(self) -> World:
        if self.dim not in (2, 3):
            raise ValueError(f"disks: dim must be 2 or 3, got {self.dim!r}")
        rubber = NeoHookean(self.E, self.nu, self.density)
        lo, hi = (0.2,) * self.dim, (0.8,) * self.dim
        v = (self.speed,) * self.dim
        cells = self.cells
        if cells is None:
            cells = self.CELLS_2D if self.dim == 2 else self.CELLS_3D
        return World(domain=(1.0,) * self.dim, cells=cells, basis=self.basis,
                     transfer=self.transfer, transfer_params=self.transfer_params,
                     gravity=(0.0,) * self.dim, walls="slip",
                     bodies=[Body(Ball(lo, 0.2), rubber, velocity=v, ppc=self.ppc, name="left"),
                             Body(Ball(hi, 0.2), rubber, velocity=tuple(-c for c in v),
                                  ppc=self.ppc, name="right")],
                     courant=self.courant, name=self.name)

    def default_t_end(self) -> float:
        return 3.5

    def title(self) -> str:
        return "colliding disks" if self.dim == 2 else "colliding balls (3D)"

    def speed_scale(self) -> float:
        """The closing speed 2 |v0| of the two disks."""
        return 2.0 * self.speed * math.sqrt(self.dim)

    def stress_scale(self) -> float:
        """rho c_p 2 |v0|: the P-wave speed c_p times the closing speed, times the density."""
        c = NeoHookean(self.E, self.nu, self.density).wave_speed
        return self.density * c * self.speed_scale()

    def summary(self, solver, series) -> dict:
        e = solver.energies()
        total = e["kinetic"] + e["strain"]
        return {"energy_min": float(total.min() / total[0]), "energy_max": float(total.max() / total[0]),
                "energy_end": float(total[-1] / total[0]),
                "strain_peak": float(e["strain"].max() / total[0])}


@dataclass
class DamBreak(Demo):
    """Water column of width ``a`` and height ``2a`` (Martin & Moyce's n^2 = 2) against the
    left wall of a tank, released at t = 0.  The bulk modulus gives a sound speed of
    ``mach_inverse`` times the largest flow speed 2 sqrt(g 2a) (weak compressibility)."""

    name = "dam-break"
    color = "speed"
    a: float = 0.25
    cells_per_a: int = 40
    ppc: int = 2
    density: float = 1000.0
    mach_inverse: float = 10.0
    viscosity: float = 0.0
    courant: float = 0.8

    def world(self) -> World:
        a = _positive("a", self.a)
        h = a / self.cells_per_a
        c = self.mach_inverse * 2.0 * math.sqrt(9.81 * 2 * a)
        water = WeaklyCompressibleFluid(bulk_modulus=self.density * c * c, density=self.density,
                                        viscosity=self.viscosity)
        nx, ny = 5 * self.cells_per_a, int(math.ceil(2.2 * self.cells_per_a))
        return World(domain=(nx * h, ny * h), cells=nx, basis=self.basis, transfer=self.transfer,
                     transfer_params=self.transfer_params,
                     bodies=[Body(Box((0.0, 0.0), (a, 2 * a)), water, ppc=self.ppc, name="water")],
                     walls="slip", courant=self.courant, name=self.name)

    def default_t_end(self) -> float:
        # the experiment's last point, T = 3.33, and a little more
        return 3.6 / math.sqrt(2 * 9.81 / self.a)

    def title(self) -> str:
        return "dam break"

    def speed_scale(self) -> float:
        """sqrt(2 g 2a): the speed of a free fall from the water column's top."""
        return math.sqrt(2.0 * G * 2.0 * self.a)

    def stress_scale(self) -> float:
        """rho g 2a: the hydrostatic pressure at the column's base."""
        return self.density * G * 2.0 * self.a

    def observe(self, solver, t) -> dict:
        x = solver.positions()
        h = solver.h
        near_floor = x[:, 1] < 2 * h
        front = float(x[near_floor, 0].max()) if near_floor.any() else float("nan")
        return {"T": t * math.sqrt(2 * 9.81 / self.a), "Z": front / self.a}

    def summary(self, solver, series) -> dict:
        T, Z = np.asarray(series["T"]), np.asarray(series["Z"])
        exp_T, exp_Z = MARTIN_MOYCE_N2_2.T
        keep = exp_T <= T.max()
        if not keep.any():  # the run ended before the first measurement
            return {"points": 0}
        sim = np.interp(exp_T[keep], T, Z)
        return {"points": int(keep.sum()),
                "mean_abs_difference": float(np.mean(np.abs(sim - exp_Z[keep]))),
                "max_abs_difference": float(np.max(np.abs(sim - exp_Z[keep]))),
                "mean_difference": float(np.mean(sim - exp_Z[keep]))}


@dataclass
class SlopeFailure(Demo):
    """Griffiths & Lane's (1999) 2:1 slope (H = 10 m, phi' = 20 deg, c' = 10 kPa, unit
    weight 20 kN/m^3) with its strength divided by ``strength_factor`` (c / F, tan(phi) /
    F), past its factor of safety (1.4), so that it fails: the soil starts from the K0
    procedure's stress, a band of plastic strain forms from the toe to the crest and the
    mass above it slides out over the firm base (Coulomb friction tan(phi')).  ``k0``: the
    K0 procedure's sigma_h / sigma_v, in (0, 1] (None: Jaky's 1 - sin(phi) of the reduced
    soil, nu / (1 - nu) at phi = 0); one the reduced soil cannot hold at the slope's base
    is refused before any work, naming the least k0 that it can."""

    name = "slope"
    color = "plastic"
    records_energies = True  # the energy dissipated
    H: float = 10.0
    strength_factor: float = 2.0
    cells_per_H: int = 40
    ppc: int = 2
    E: float = 1e8
    nu: float = 0.3
    unit_weight: float = 20e3
    friction_angle: float = 20.0
    cohesion: float = 10e3
    #: the step as a share of h / (c_p + the fall's speed); None: the basis's (step_courant)
    courant: float | None = None
    k0: float | None = None

    def soil(self):
        from ..materials import MohrCoulomb

        F = _positive("strength_factor", self.strength_factor)
        return MohrCoulomb(E=self.E, nu=self.nu,
                           density=_positive("unit_weight", self.unit_weight) / G,
                           friction_angle=self.friction_angle,
                           cohesion=self.cohesion).reduced(F)

    def world(self) -> World:
        from ..model.geometry import Polygon

        H = _positive("H", self.H)
        h = H / self.cells_per_H
        # crest 2H long, the 2:1 face, and 4H of firm base beyond the toe for the run-out
        nx, ny = 8 * self.cells_per_H, int(math.ceil(1.4 * self.cells_per_H))
        slope = Polygon([(0.0, 0.0), (4 * H, 0.0), (2 * H, H), (0.0, H)])
        mu = math.tan(math.radians(self.friction_angle))
        return World(domain=(nx * h, ny * h), cells=nx, basis=self.basis, transfer=self.transfer,
                     transfer_params=self.transfer_params,
                     bodies=[Body(slope, self.soil(), ppc=self.ppc, name="slope")],
                     walls={"default": "roller", "bottom": Wall("friction", mu), "top": None,
                            "right": None},
                     initial_stress=self.initial_stress(), courant=self.step_courant(),
                     name=self.name)

    def step_courant(self) -> float:
        """The courant number given, or the basis's: 1.0 of h / (c_p + the fall's speed)
        for the padded quadratic B-spline (0.95 h / c_p here: with it MLS-MPM loses energy
        up to 1.0 of h / c_p on every lattice and is stable to 1.2 on a body's, its lumped
        mass never small against its stiffness: docs/results.md, "Above the CFL step"; the
        run-out, 8.25 m, and the energy budget as at 0.5 and 0.8 in half the steps of 0.5);
        0.8 for the other bases, whose steps above h / c_p were not measured (the linear
        element's is its CFL bound)."""
        if self.courant is not None:
            return self.courant
        return 1.0 if self.basis == "uniform-bspline2" else 0.8

    def buoyant_unit_weight(self) -> float:
        """The unit weight the K0 procedure weighs the slope by (dry: its own)."""
        return _positive("unit_weight", self.unit_weight)

    def initial_stress(self):
        """The K0 procedure at ``k0`` (None: each material's Jaky's), checked before any
        work against the reduced soil's Mohr-Coulomb surface at the deepest point, under
        the crest (sigma_v = gamma H; f is linear in sigma_v, so the whole slope holds
        if that point does): the least k0 the soil holds there is named."""
        from ..model.geostatic import K0, jaky_k0

        if self.k0 is not None and (isinstance(self.k0, bool)
                                    or not isinstance(self.k0, (int, float))
                                    or not 0.0 < self.k0 <= 1.0):
            raise ValueError(f"demo {self.name}: k0 (--param k0=K) must lie in (0, 1] "
                             f"(sigma_h / sigma_v of ground at rest), got {self.k0!r}")
        soil = self.soil()
        k = jaky_k0(soil) if self.k0 is None else float(self.k0)
        sv = self.buoyant_unit_weight() * _positive("H", self.H)
        sin, cos = (f(math.radians(soil.friction_angle)) for f in (math.sin, math.cos))
        need = ((1.0 - sin) * sv - 2.0 * soil.cohesion * cos) / ((1.0 + sin) * sv)
        if sv > 0.0 and k < need * (1.0 + 1e-9):
            given = ("Jaky's" if self.k0 is None and soil.friction_angle > 0 else
                     "nu / (1 - nu), Jaky's without friction" if self.k0 is None else
                     "given")
            raise ValueError(
                f"demo {self.name}: the K0 stress (K0 = {k:.4g}, {given}) lies outside the "
                f"reduced soil's strength (phi = {soil.friction_angle:.4g} deg, c = "
                f"{soil.cohesion:.4g} Pa: friction_angle and cohesion / strength_factor "
                f"{self.strength_factor:g}) at the slope's base, sigma_v = {sv:.4g} Pa: give "
                f"--param k0=K with K >= {min(need * (1 + 1e-6), 1.0):.4g} (at most 1), or "
                f"raise cohesion or friction_angle, or lower strength_factor")
        return K0(self.k0)

    def default_t_end(self) -> float:
        # the slide runs for some 10 times sqrt(H / g)
        return 10.0 * math.sqrt(self.H / G)

    def title(self) -> str:
        return f"slope failure, strength / {self.strength_factor:g}"

    def speed_scale(self) -> float:
        """sqrt(2 g H): a fall from the crest's height."""
        return math.sqrt(2.0 * G * self.H)

    def stress_scale(self) -> float:
        return self.unit_weight * self.H

    def strain_scale(self) -> float:
        """1: the failure surface (strains of tenths and more) against the intact mass."""
        return 1.0

    def observe(self, solver, t) -> dict:
        from ..model.geometry import deposit_front

        # the deposit's front: 2% of H thick
        return {"front": deposit_front(solver.positions(), solver.h, 0.02 * self.H)}

    def summary(self, solver, series) -> dict:
        """Run-out beyond the toe; energies per metre of slope (plane strain, J/m): the
        potential energy the slide released, the energy dissipated (released and not
        moving at the end), of which the work on the soil (plastic, and the elastic
        change) and the rest (the floor's friction, the transfer's own damping)."""
        e = solver.energies()
        total = e["kinetic"] + e["strain"] + e["gravity"]
        toe = 4.0 * self.H
        released = float(e["gravity"][0] - e["gravity"][-1])
        dissipated = released + float(e["kinetic"][0] - e["kinetic"][-1])
        return {"strength_factor": self.strength_factor,
                "runout": float(series["front"][-1] - toe),
                "runout_over_H": float((series["front"][-1] - toe) / self.H),
                "potential_energy_released": released,
                "energy_dissipated": dissipated,
                "work_on_the_soil": float(e["strain"][-1] - e["strain"][0]),
                "friction_and_transfer_loss": float(total[0] - total[-1]),
                "kinetic_energy_end": float(e["kinetic"][-1])}


@dataclass
class SubmarineSlope(SlopeFailure):
    """Griffiths & Lane's slope under ``water_depth`` of sea above its crest, of a weaker
    soil (strength / ``strength_factor``): saturated (porosity ``porosity``), it weighs its
    buoyant weight below the still-water level, starts from the K0 stress of that weight,
    and fails with its pore water: each particle's excess pore pressure follows the
    volumetric strains (dp = -(K_w / n) [(1 - n) d eps_s + n d eps_w]) while the water
    flows against the skeleton (Darcy), the soil's law acting on the effective stress.  The sea acts on the sliding soil through its pressure and buoyancy
    (the hydrostatic pressure of the level); its own flow and drag on the slide are not
    modelled.  ``water_modulus`` is the pore water's bulk modulus: 0.1 GPa, a
    compressibility 22 times water's, keeps the undrained wave at 1.7 times the dry
    skeleton's, and so the time step (2.2 GPa would cut it 3.4 times; the undrained
    response is stiff either way: K_w / n is 1.9 times the skeleton's P-wave modulus).
    ``analysis`` "coupled" (the pore water flows, ``conductivity`` k) or "undrained".
    ``smoothing`` the pore pressure's (``Water.smoothing``): "cell", the step's pore strain
    averaged over each grid cell drives the pressure ("none": each particle's own, which
    grows a particle-scale checkerboard in the slide, docs/results.md).  Coloured by the
    plastic strain, the level drawn; ``--color pore-pressure`` shows the excess pore
    pressure; the JSON reports its extremes, RMS and roughness (the RMS within the cells,
    :func:`pressure_roughness`)."""

    name = "submarine-slope"
    color = "plastic"
    transfer: str = "musl"
    courant: float = 0.5  # MUSL with the pore water: measured at 0.5
    strength_factor: float = 3.0
    cells_per_H: int = 42
    water_depth: float = 5.0
    porosity: float = 0.4
    conductivity: float = 1.0e-4
    water_modulus: float = 1.0e8
    analysis: str = "coupled"
    smoothing: str = "cell"

    @property
    def level(self) -> float:
        return self.H + _positive("water_depth", self.water_depth)

    def world(self) -> World:
        from ..materials.pore_water import PoreWater
        from ..model.geometry import Polygon
        from ..model.water import Water

        H = _positive("H", self.H)
        h = H / self.cells_per_H
        # the domain reaches above the level (drawn): crest 2H, the face, 4H of base
        nx = 8 * self.cells_per_H
        ny = int(math.ceil(max(1.4 * H, self.level + 0.1 * H) / h))
        slope = Polygon([(0.0, 0.0), (4 * H, 0.0), (2 * H, H), (0.0, H)])
        mu = math.tan(math.radians(self.friction_angle))
        water = PoreWater(porosity=self.porosity, conductivity=self.conductivity,
                          bulk_modulus=self.water_modulus)
        return World(domain=(nx * h, ny * h), cells=nx, basis=self.basis, transfer=self.transfer,
                     transfer_params=self.transfer_params,
                     bodies=[Body(slope, self.soil(), ppc=self.ppc, name="slope", water=water)],
                     walls={"default": "roller", "bottom": Wall("friction", mu), "top": None,
                            "right": None},
                     initial_stress=self.initial_stress(), courant=self.courant,
                     name=self.name,
                     water=Water(self.analysis, level=self.level, smoothing=self.smoothing))

    def buoyant_unit_weight(self) -> float:
        """Submerged: gamma - gamma_w, the weight the K0 procedure takes below the level."""
        return _positive("unit_weight", self.unit_weight) - 1000.0 * G

    def title(self) -> str:
        return f"submarine slope, strength / {self.strength_factor:g}"

    def pore_pressure_scale(self) -> float:
        """The buoyant weight of the slope's height, (gamma_sat - gamma_w) H: the excess
        pressure that would carry it."""
        return (self.unit_weight - 1000.0 * G) * self.H

    def summary(self, solver, series) -> dict:
        out = super().summary(solver, series)
        pw = solver.read("pw")
        out.update(water_level=self.level, water_depth_above_crest=self.water_depth,
                   analysis=self.analysis, water_modulus=self.water_modulus,
                   excess_pore_pressure_max=float(pw.max()),
                   excess_pore_pressure_min=float(pw.min()),
                   excess_pore_pressure_rms=float(np.sqrt(np.mean(pw ** 2))),
                   excess_pore_pressure_roughness=pressure_roughness(solver, pw),
                   smoothing=self.smoothing)
        return out


def pressure_roughness(solver, pw) -> float:
    """The RMS of each particle's pressure less its grid cell's volume-weighted mean: the
    particle-scale pattern the grid cannot see (0 where the pressure is constant per cell)."""
    x, vol = solver.positions(), solver.read("vol")
    h, origin = solver.h, np.asarray(solver.origin)
    cells = np.floor((x - origin) / h).astype(np.int64)
    _, which = np.unique(cells, axis=0, return_inverse=True)
    which = which.reshape(-1)
    mean = np.bincount(which, vol * pw) / np.bincount(which, vol)
    return float(np.sqrt(np.mean((pw - mean[which]) ** 2)))


DEMOS = {cls.name: cls for cls in (ColumnCollapse, Disks, DamBreak, SlopeFailure,
                                   SubmarineSlope)}


def get_demo(name: str, **params) -> Demo:
    if name not in DEMOS:
        raise ValueError(f"unknown demo {name!r}: choose one of {', '.join(DEMOS)}")
    cls = DEMOS[name]
    known = set(cls.__dataclass_fields__)
    unknown = sorted(set(params) - known)
    if unknown:
        raise ValueError(f"demo {name!r} has no parameter {', '.join(unknown)}: it takes "
                         f"{', '.join(sorted(known))}")
    return cls(**params)


def quantity(solver, name):
    """Per-particle values to colour by."""
    d = solver.dim
    if name == "speed":
        return np.linalg.norm(solver.velocities(), axis=1)
    if name == "pressure":
        return -np.trace(solver.stresses(), axis1=1, axis2=2) / d
    if name == "von-mises":
        s = solver.stresses()
        dev = s - np.trace(s, axis1=1, axis2=2)[:, None, None] / d * np.eye(d)
        return np.sqrt(1.5 * np.sum(dev * dev, axis=(1, 2)))
    if name == "plastic":
        if "plastic" not in solver.needs:
            raise ValueError("colour 'plastic' needs a plastic material (sand) in the scene")
        return solver.read("plastic")
    if name == "body":
        return solver.scene.body_index.astype(float)
    if name == "pore-pressure":
        if "pw" not in solver.program().particle_fields:
            raise ValueError("colour 'pore-pressure' needs a scene whose water keeps an excess "
                             "pore pressure (an undrained or coupled analysis)")
        return solver.read("pw")
    raise ValueError(f"unknown colour quantity {name!r}: choose one of {', '.join(QUANTITIES)}")


def color_range(demo, name, bodies=1):
    """The colour range (vmin, vmax) of quantity ``name`` over a whole run of ``demo``,
    its label and unit: speed 0 to the demo's speed scale, pressure and von Mises stress
    0 to its stress scale, plastic strain 0 to its strain scale, body 0 to ``bodies`` - 1.
    Values beyond the range take its end colours."""
    if name == "speed":
        return (0.0, demo.speed_scale()), "speed", "m/s"
    if name == "pressure":
        return (0.0, demo.stress_scale()), "pressure", "Pa"
    if name == "von-mises":
        return (0.0, demo.stress_scale()), "von Mises stress", "Pa"
    if name == "plastic":
        return (0.0, demo.strain_scale()), "plastic strain", ""
    if name == "body":
        return (0.0, float(max(1, bodies - 1))), "body", ""
    if name == "pore-pressure":
        scale = demo.pore_pressure_scale()
        return (-scale, scale), "excess pore pressure", "Pa"
    raise ValueError(f"unknown colour quantity {name!r}: choose one of {', '.join(QUANTITIES)}")


@dataclass
class DemoResult:
    """What a demo run produced: files, times (simulation and rendering apart), series."""

    name: str
    out: str | None
    frames: int
    particles: int
    steps: int
    t_end: float
    dt: float
    compile_seconds: float
    simulation_seconds: float
    render_seconds: float
    series: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    memory: dict = field(default_factory=dict)
    interrupted: object = None  # the RunInterrupted that stopped it (None: it ran to t_end)

    @property
    def simulated_per_wall_second(self) -> float:
        return self.t_end / self.simulation_seconds if self.simulation_seconds > 0 else math.inf

    def report(self) -> str:
        lines = [f"{self.name}: {self.particles} particles, {self.steps} steps of dt = {self.dt:.3g} s"
                 f" to t = {self.t_end:.3g} s, {self.frames} frames",
                 f"  compile {self.compile_seconds:.2f} s, simulation {self.simulation_seconds:.2f} s "
                 f"({self.simulated_per_wall_second:.3g} simulated s per wall s, "
                 f"{self.particles * self.steps / max(self.simulation_seconds, 1e-12) / 1e6:.2f} "
                 f"M particle-steps/s), rendering {self.render_seconds:.2f} s",
                 f"  memory {self.memory.get('particle_bytes', 0)} B/particle, "
                 f"{self.memory.get('node_bytes', 0)} B/node"]
        for k, v in self.summary.items():
            lines.append(f"  {k}: {v:.4g}" if isinstance(v, float) else f"  {k}: {v}")
        if self.out:
            lines.append(f"  wrote {self.out}")
        return "\n".join(lines)


def run_frames(solver, t_end, frames, movie=None, color=None, fields=None, progress=None,
               observe=None, allow_many_steps=False) -> dict:
    """Run ``solver`` from its time t0 to ``t_end`` in ``frames`` equal parts; at the start
    and after each part ``movie`` gets the particles coloured by ``color``, ``fields`` the
    particle fields and ``observe(solver, t)`` a dict of values.  Returns those values'
    series (with ``t``) as arrays.  A Ctrl-C, SIGTERM or SIGHUP under
    :func:`~timpm.platform.interrupt.deferred_sigint` stops the run at a step boundary
    (:class:`~timpm.platform.interrupt.RunInterrupted`): the state there is added as a last
    frame and the exception carries the series so far (``series``)."""
    from ..platform.interrupt import RunInterrupted

    series = {}
    bar = Progress(frames, progress)
    solver.compile()
    t0 = solver.t  # 0 for a new run (t0 + (t_end - t0) k / frames: t_end k / frames)

    def frame():
        if observe is not None:
            for key, value in observe(solver, solver.t).items():
                series.setdefault(key, []).append(value)
        series.setdefault("t", []).append(solver.t)
        if movie is not None:
            movie.add(solver.positions(), quantity(solver, color), t=solver.t)
        if fields is not None:
            fields.write(solver)

    try:
        for k in range(frames + 1):
            if k:
                solver.run(t_end=t0 + (t_end - t0) * k / frames, progress=False,
                           allow_many_steps=allow_many_steps)
            frame()
            bar.update(k)
    except RunInterrupted as stop:  # the state where it stopped, whole: a last frame
        frame()
        stop.series = {k: np.asarray(v) for k, v in series.items()}
        raise
    finally:
        bar.close()
    return {k: np.asarray(v) for k, v in series.items()}


def run_demo(name, movie=None, frames=60, color=None, progress=None, mode="auto",
             fields=None, allow_many_steps=False, **params) -> DemoResult:
    """Run demo ``name`` (``DEMOS``), drawing its frames into ``movie`` (None: no images).

    ``frames`` frames are spread evenly over the run (plus the initial state); ``params``
    override the demo's parameters (``t_end``, resolution, material constants ...).
    ``movie`` is a sink such as :class:`timpm.output.render.Movie`: ``movie.start(world,
    color, value_range, label, unit, title)`` before the run (the range of
    :func:`color_range`, fixed for the run), ``movie.add(positions, values, t)`` at every
    frame, ``movie.close()`` after it; its ``out`` and ``seconds`` go into the result.
    ``fields`` (a :class:`timpm.output.fields.FieldWriter`) gets the particle fields at
    every frame.  A run of more than :data:`~timpm.platform.checks.MAX_STEPS` steps (a time step
    the CFL limit shrank) is refused before it starts unless ``allow_many_steps``.
    Stopped by a signal under :func:`~timpm.platform.interrupt.deferred_sigint` (the command
    line's), it closes the movie on the frames so far and returns the result of the run to
    where it stopped, its ``interrupted`` the :class:`~timpm.platform.interrupt.RunInterrupted`.
    """
    from ..platform.interrupt import RunInterrupted

    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise ValueError(f"frames must be a positive integer, got {frames!r}")
    demo = get_demo(name, **params)
    world = demo.world()
    color = color or demo.color
    t_end = demo.end_time()
    step_count(t_end, world.dt, allow_many_steps)
    solver = Solver(world, mode=mode, energies=demo.records_energies,
                    record_every=max(1, int(round(t_end / world.dt / 200))))
    quantity(solver, color)  # an unknown or unavailable colour fails before the run
    if movie is not None:
        value_range, label, unit = color_range(demo, color, len(world.bodies))
        movie.start(world, color, value_range=value_range, label=label, unit=unit,
                    title=demo.title())
    interrupted = None
    try:
        series = run_frames(solver, t_end, frames, movie=movie, color=color, fields=fields,
                            progress=progress, observe=demo.observe, allow_many_steps=True)
    except RunInterrupted as stop:  # the GIF and the record of the run so far
        interrupted, series = stop, stop.series
    if movie is not None:
        movie.close()
    render_seconds = movie.seconds if movie is not None else 0.0
    result = DemoResult(name=name, out=None if movie is None else str(movie.out), frames=frames,
                        particles=world.n_particles, steps=solver.step, t_end=solver.t,
                        dt=world.dt, compile_seconds=solver.compile_seconds,
                        simulation_seconds=solver.run_seconds, render_seconds=render_seconds,
                        series=series, memory=solver.memory(), interrupted=interrupted)
    result.summary = demo.summary(solver, result.series)
    result.solver = solver
    return result
