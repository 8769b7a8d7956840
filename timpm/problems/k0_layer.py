"""A layer of soil at rest under its own weight, started from the K0 procedure's stress."""
from dataclasses import dataclass

import numpy as np

from ..platform.checks import whole
from ..platform.errors import InputError
from .base import Problem, ProblemScene, check_positive, lattice


@dataclass(frozen=True)
class K0Layer(Problem):
    """A Mohr-Coulomb layer of height ``H`` on a rigid base, ``width`` cells wide between
    roller walls (plane strain), under gravity, its particles started from the geostatic
    stress sigma_v = rho g (H - y), sigma_h = sigma_zz = K0 sigma_v (``k0`` = 0: Jaky's 1 -
    sin(phi)).  That state is the exact solution at rest: u = 0 and the stress unchanged;
    the record holds the relative RMS errors of sigma_v and sigma_h against it
    (``sigma_v_rms_error``, ``sigma_h_rms_error``), the largest displacement and the
    largest kinetic energy per unit weight of the layer over the run.
    """

    density: float = 2000.0
    E: float = 1e8
    nu: float = 0.3
    friction_angle: float = 30.0
    cohesion: float = 10e3
    k0: float = 0.0
    gravity: float = -9.81
    H: float = 10.0
    width: int = 4

    name = "k0-layer"
    title = "Soil layer at rest from the K0 procedure's geostatic stress"
    section = "issue 34"
    elements = 20
    ppc = 2
    dt = 1e-3
    t_end = 1.0
    dim = 2

    def __post_init__(self):
        check_positive(self, "density", "E", "H")
        if not (isinstance(self.cohesion, (int, float)) and not isinstance(self.cohesion, bool)
                and np.isfinite(self.cohesion) and self.cohesion >= 0.0):
            raise InputError(f"{self.name}: parameter cohesion must be >= 0 (a cohesionless "
                             f"soil: 0), got {self.cohesion!r}", "cohesion")
        try:
            object.__setattr__(self, "width", whole("width", self.width))
        except ValueError:
            raise InputError(f"{self.name}: width must be a positive number of cells, got "
                             f"{self.width!r}", "width") from None
        if not (self.gravity < 0.0):
            raise InputError(f"{self.name}: gravity must point down y (< 0), got "
                             f"{self.gravity!r}", "gravity")
        if not (0.0 <= self.k0 <= 1.0):
            raise InputError(f"{self.name}: k0 must lie in (0, 1], or be 0 for Jaky's 1 - sin "
                             f"phi, got {self.k0!r}", "k0")

    @property
    def dt_rule(self) -> str:
        return f"min({self.dt:g} s, 0.5 h / c)"

    def cells(self, elements):
        return (self.width, elements)

    def domain_length(self):
        return self.H

    @property
    def soil(self):
        from ..materials import MohrCoulomb
        return MohrCoulomb(E=self.E, nu=self.nu, density=self.density,
                           friction_angle=self.friction_angle, cohesion=self.cohesion)

    @property
    def k0_ratio(self) -> float:
        from ..model.geostatic import jaky_k0
        return self.k0 if self.k0 > 0.0 else jaky_k0(self.soil)

    def geostatic(self, x0):
        """sigma_v and sigma_h (> 0, compression) at the positions (n, 2)."""
        sv = self.density * -self.gravity * (self.H - np.asarray(x0)[:, 1])
        return sv, self.k0_ratio * sv

    def scene(self, elements=None, ppc=None, basis="linear", mass=None, dt=None,
              placement=None, stress_update="study", allow_unstable_dt=False,
              damping=None, projection=None, transfer="musl", pic_fraction=None,
              integrator=None, transfer_params=None):
        from ..model.model import Model, Wall, with_pic_fraction

        if stress_update != "study":
            raise ValueError(f"{self.name} is Mohr-Coulomb soil: it takes no stress_update "
                             f"(got {stress_update!r})")
        elements, ppc, placement, basis_cls = self.numerics(elements, ppc, placement, basis)
        mass, projection, integrator = self.scheme(basis_cls, mass, projection, integrator,
                                                   transfer)
        self.grid(elements, basis_cls)  # checks the count
        n, h = int(elements), self.H / elements
        soil = self.soil
        extra, wave = self.model_options(soil, h)
        dt = min(self.dt, 0.5 * h / wave) if dt is None else dt
        side = basis_cls.support if basis_cls.uniform_nodes and basis_cls.name != "linear" else 0
        top = max(side, max(1, basis_cls.support - 1))
        X, volume = lattice((self.width, n), ppc, h, placement)
        sv, sh = self.geostatic(X)
        stress = np.zeros((len(X), 3, 3))
        stress[:, 0, 0] = stress[:, 2, 2] = -sh
        stress[:, 1, 1] = -sv
        model = Model(basis=basis_cls.name, origin=(-side * h, -side * h), h=h,
                      elements=(self.width + 2 * side, n + side + top),
                      positions=X, volume=volume, materials=(soil,), dt=dt,
                      transfer=transfer, mass_matrix=mass, projection=projection,
                      gravity=(0.0, self.gravity), damping=0.0 if damping is None else damping,
                      transfer_params=with_pic_fraction(transfer, pic_fraction,
                                                        transfer_params),
                      integrator=integrator,
                      walls=(Wall("roller"), Wall("roller"), Wall("sticky"), None),
                      wall_cells=((side, side + self.width), (side, side + n + top)),
                      initial_stress=stress, name=self.name, **extra)
        return ProblemScene(model, h / wave, "h / c", allow_unstable_dt)

    def model_options(self, soil, h):
        """More of the Model's arguments (a variant's: its water), and the wave speed that
        bounds the time step."""
        return {}, soil.wave_speed

    def displacement(self, x0, t, stress_update="study"):
        return np.zeros_like(np.asarray(x0, dtype=float).reshape(-1, 2))

    def velocity(self, x0, t):
        return self.displacement(x0, t)

    def summary(self, x0, solver, stress_update) -> dict:
        X = np.asarray(x0, dtype=float).reshape(-1, 2)
        sv, sh = self.geostatic(X)
        sig = solver.read("sigma")

        def rms(num, ref):
            return float(np.sqrt(np.mean(num ** 2) / np.mean(ref ** 2)))

        u = solver.positions() - X
        out = {"k0": self.k0_ratio,
               "sigma_v_rms_error": rms(-sig[:, 1, 1] - sv, sv),
               "sigma_h_rms_error": rms(-sig[:, 0, 0] - sh, sh),
               "max_displacement": float(np.abs(u).max()),
               "max_speed": float(np.abs(solver.velocities()).max()),
               "plastic_strain_max": float(solver.read("plastic").max())}
        en = solver.energies() if solver.record_energies else None
        if en is not None:
            weight = float(np.sum(solver.read("m"))) * -self.gravity * self.H
            out["max_kinetic_energy_per_weight"] = float(np.max(en["kinetic"]) / weight)
        return out

    def monitored_particle(self, x0):
        X = np.asarray(x0, dtype=float).reshape(-1, 2)
        return int(np.argmin((X[:, 0] - X[:, 0].mean()) ** 2 + (X[:, 1] - 0.5 * self.H) ** 2))
