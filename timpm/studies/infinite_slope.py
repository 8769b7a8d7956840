"""An infinite slope's factor of safety by strength reduction, against its closed forms.

The slope is posed in its own frame: x down the slope (periodic: the layer has no ends),
y normal to it, gravity tilted by the slope angle beta, g = |g| (sin beta, -cos beta).  A
layer of cohesionless Mohr-Coulomb soil (c' = 0, friction angle phi', associated flow psi
= phi') of depth ``depth`` rests on a rough rigid base (a sticky wall).  Its initial
stress is the gravity loading's (a damped run under gravity to rest, with the trial's
reduced strength), and the factor is bisected as for any slope
(:mod:`timpm.studies.factor_of_safety`).  The closed forms (plane parallel to the
surface, c' = 0; e.g. Craig's Soil Mechanics, the infinite slope):

- ``water="dry"`` or ``"submerged"`` (the slope under still water: the buoyant weight):
  F = tan(phi') / tan(beta);
- ``water="seepage"`` (steady seepage parallel to the slope, the water table at the
  surface): F = (gamma' / gamma_sat) tan(phi') / tan(beta), gamma' = gamma_sat - gamma_w.

Why associated flow by default: in plastic simple shear the mobilised ratio on the
plane parallel to the surface is tan(phi*) = sin(phi') cos(psi) / (1 - sin(phi')
sin(psi)) (Davis 1968), tan(phi') only where psi = phi' (the zero-extension line of the
flow is then the stress characteristic).  With another ``dilation_angle`` the closed form
is Davis's: the F at which tan(phi*) of the reduced strength (tan(phi_F) = tan(phi') / F,
psi_F = min(psi, phi_F)) equals the ratio the slope asks, tan(beta) (times gamma_sat /
gamma' with seepage): 1.477 for psi = 0, against the classical 1.586.
"""
import math
from dataclasses import dataclass

from .factor_of_safety import add_bisection_arguments
from .limit_equilibrium import GAMMA_W

__all__ = ["InfiniteSlope", "WATERS", "add_parser"]

#: the water conditions of the slope
WATERS = ("dry", "submerged", "seepage")
G = 9.81


@dataclass(frozen=True)
class InfiniteSlope:
    """See the module.  Angles in degrees, unit weight (saturated, or dry) in N/m^3,
    lengths in m, E in Pa; ``cells`` along the period x, ``h`` the cell size."""

    beta: float = 20.0
    friction_angle: float = 30.0
    unit_weight: float = 20e3
    water: str = "submerged"
    depth: float = 5.0
    h: float = 0.5
    cells: int = 4
    E: float = 1e7
    nu: float = 0.3
    ppc: int = 2
    damping: float = 0.2
    t_end: float = 2.0
    loading_time: float = 20.0
    dilation_angle: float | None = None  # None: associated, psi = phi'

    def __post_init__(self):
        if self.water not in WATERS:
            raise ValueError(f"infinite slope: unknown water {self.water!r}: choose one of "
                             f"{', '.join(WATERS)}")
        if not (0.0 < self.beta < self.friction_angle < 90.0) and self.water != "seepage":
            raise ValueError(f"infinite slope: need 0 < beta < phi' < 90 degrees (a slope "
                             f"that can stand dry), got beta {self.beta}, phi' "
                             f"{self.friction_angle}")
        if not (0.0 < self.beta < 90.0 and 0.0 < self.friction_angle < 90.0):
            raise ValueError("infinite slope: beta and phi' must lie in (0, 90) degrees")
        if self.dilation_angle is not None and not (
                0.0 <= self.dilation_angle <= self.friction_angle):
            raise ValueError(f"infinite slope: the dilation angle must lie in [0, phi'], "
                             f"got {self.dilation_angle!r}")
        if self.water != "dry" and not self.unit_weight > GAMMA_W:
            raise ValueError(f"infinite slope: a saturated unit weight must exceed the "
                             f"water's {GAMMA_W:g} N/m^3, got {self.unit_weight:g}")
        for key in ("unit_weight", "depth", "h", "E", "t_end"):
            if not getattr(self, key) > 0.0:
                raise ValueError(f"infinite slope: {key} must be positive, got "
                                 f"{getattr(self, key)!r}")
        n = self.depth / self.h
        if abs(n - round(n)) > 1e-9 or round(n) < 2:
            raise ValueError(f"infinite slope: depth / h must be a whole number of cells "
                             f"(at least 2), got {n:g}")

    @property
    def psi(self) -> float:
        return self.friction_angle if self.dilation_angle is None else self.dilation_angle

    @property
    def exact(self) -> float:
        """The closed-form factor of safety (the module): the classical one with
        associated flow, Davis's otherwise."""
        asked = math.tan(math.radians(self.beta))  # tau / sigma_n' on the parallel plane
        if self.water == "seepage":
            asked *= self.unit_weight / (self.unit_weight - GAMMA_W)
        tan_phi = math.tan(math.radians(self.friction_angle))
        if self.psi == self.friction_angle:
            return tan_phi / asked

        def mobilised(F):  # Davis's tan(phi*) of the strength divided by F
            phi = math.atan(tan_phi / F)
            psi = min(math.radians(self.psi), phi)
            return math.sin(phi) * math.cos(psi) / (1.0 - math.sin(phi) * math.sin(psi))

        low, high = 1e-3, 1e3  # mobilised falls as F grows: bisect for it = asked
        for _ in range(200):
            mid = math.sqrt(low * high)
            low, high = (mid, high) if mobilised(mid) > asked else (low, mid)
        return math.sqrt(low * high)

    def world(self):
        """The layer in the slope's frame (the module), loaded under gravity to rest."""
        from ..materials import MohrCoulomb, PoreWater
        from ..model.geostatic import GravityLoading
        from ..model.water import Water
        from ..model.world import Body, Box, World

        b = math.radians(self.beta)
        soil = MohrCoulomb(E=self.E, nu=self.nu, density=self.unit_weight / G,
                           friction_angle=self.friction_angle, cohesion=0.0,
                           dilation_angle=self.psi)
        pores = None if self.water == "dry" else PoreWater(porosity=0.4, conductivity=1e-5)
        water = {"dry": None,
                 "submerged": Water("drained", level=self.depth + self.h),
                 "seepage": Water("drained", level=self.depth, seepage="parallel"),
                 }[self.water]
        width = self.cells * self.h
        layer = Body(Box((0.0, 0.0), (width, self.depth)), soil, ppc=self.ppc,
                     water=pores, name="layer")
        return World(
            domain=(width, self.depth + 2 * self.h), cells=self.cells, bodies=(layer,),
            basis="linear", transfer="musl", damping=self.damping,
            gravity=(G * math.sin(b), -G * math.cos(b)),
            walls={"left": "periodic", "right": "periodic", "bottom": "sticky", "top": None},
            initial_stress=GravityLoading(t_max=self.loading_time), water=water,
            name="infinite-slope")

    def factor_of_safety(self, low=0.5, high=2.5, tolerance=0.02, creep=1e-3,
                         progress=None):
        """The bisection (:func:`timpm.studies.factor_of_safety.factor_of_safety`) and the
        record, with the closed form and the error beside it."""
        from .factor_of_safety import factor_of_safety

        record, _ = factor_of_safety(self.world(), self.t_end, low=low, high=high,
                                     tolerance=tolerance, creep=creep, progress=progress)
        F = record["factor_of_safety"]
        record.update(study="infinite-slope", water=self.water, beta=self.beta,
                      friction_angle=self.friction_angle, dilation_angle=self.psi,
                      unit_weight=self.unit_weight, depth=self.depth, exact=self.exact,
                      relative_error=(F - self.exact) / self.exact)
        return record


def add_parser(subparsers):
    p = subparsers.add_parser(
        "infinite-slope", help="an infinite slope's factor of safety against its closed form",
        description="A cohesionless layer in the slope's frame (x periodic, gravity tilted), "
                    "dry, submerged or with seepage parallel to the slope; its strength "
                    "divided by F until it slides (timpm study factor-of-safety's bisection).")
    p.add_argument("--water", choices=WATERS, default="submerged",
                   help="dry, submerged (still water above) or seepage (parallel to the "
                        "slope, water table at the surface); default submerged")
    p.add_argument("--beta", type=float, default=20.0, help="slope angle, degrees (20)")
    p.add_argument("--phi", type=float, default=30.0, help="friction angle phi', degrees (30)")
    p.add_argument("--psi", type=float, default=None,
                   help="dilation angle, degrees (default phi': associated; the closed "
                        "form is Davis's otherwise)")
    add_bisection_arguments(p, bracket=(0.5, 2.5))
    p.add_argument("--json", metavar="FILE", help="write the record")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    from ..platform.argtypes import add_runtime_arguments

    add_runtime_arguments(p)
    p.set_defaults(plot=None)
    return p
