"""The contract every constitutive model keeps.

A material is a value (its parameters, checked on construction) and a compiled unit.  The
value says what the engine compiles and with which numbers:

- ``particle_fields(dim)``: the particle state the law keeps besides stress and volume,
  name -> :class:`~timpm.platform.declare.Field` (``F``, the deformation gradient;
  ``plastic``, the plastic strain; ``J``; ``eps``; its own: a hardening variable); the
  engine allocates the union of a scene's declarations (a name two laws declare is one
  field: they must declare it alike), each field from its ``initial`` value, or from the
  law's ``initial_state`` where the scene starts from a stress;
- ``flags()``: the compile-time choices of the law (part of the feature set);
- ``constants(dt, h)``: the run-time numbers its update reads, by name (``CONSTANTS``),
  for a run with time step dt on a grid of spacing h, every derived constant computed here
  once, in double precision; ``density`` among them (the
  volume guard reads V0 = m_p / density);
- ``free_expansion``: the law lets a particle expand without bound (a tension cut-off);
- ``energy_function``: the law has a stored energy W(F) (hyperelastic); its unit then
  gives ``energy(s, p)`` = W(F_p) V0_p, which the records report as the strain energy
  (otherwise the work sigma : d_eps V integrated along the path, which holds dissipation);
  a law whose compile-time flags decide it overrides ``has_energy_function(flags)``.
- ``stress_from_F``: the Cauchy stress is a function of F alone (no path); its unit
  then gives ``stress(s, p, F)``, which the Runge-Kutta integrator evaluates at each
  stage (``Model(integrator="rk4")``) after setting F_p; a law that keeps more state
  (a strain) sets it from F there.

The compiled unit is the same class built by :meth:`unit` with a getter per constant
(``self.c.mu()``) and one ``@ti.func``::

    sigma_new = unit.update(s, p, grad_du, sigma_old)

called in G2P with the displacement-increment gradient ``grad_du`` of particle ``p``
after the engine stored the particle's new volume in ``s.vol[p]``.  ``s`` is the engine's
particle state (:class:`timpm.engine.views.MaterialState`, not the program): fields ``m,
vol, F, J, plastic, eps, ezz``, the dimension ``s.dim``, the flag ``s.update_volume`` and
``s.accumulate(ref, value)`` (``ref += value`` as the driver needs it).  The update
advances the state the law owns and returns the new Cauchy stress.
"""
import math

import taichi as ti

from ..platform.declare import Field, Param
from ..platform.errors import InputError
from .svd import svd

__all__ = ["Material", "SolidMaterial", "MAX_INITIAL_LOG_STRAIN"]

#: the largest elastic log strain an initial stress may ask of a Hencky law (beyond it the
#: stretch exp(eps) over- or underflows toward 0 or infinity: a soil of E = 1 Pa under its
#: weight started from F = 0)
MAX_INITIAL_LOG_STRAIN = 1.0


@ti.data_oriented
class Material:
    """Common interface: ``density``, ``wave_speed`` (for the CFL limit), the particle
    state it keeps (``particle_fields``)."""

    name = ""
    #: its parameters (the constructor's arguments): unit, meaning, range; the defaults are
    #: the constructor's.  Python and the scene files check a value against them alike
    PARAMS = {"density": Param(unit="kg/m^3", doc="mass density", low=0.0, low_open=True)}
    #: names of the run-time constants the update reads
    CONSTANTS = ("density",)
    #: wave speed (m/s) that bounds the time step, set by each material
    wave_speed = 0.0
    #: True where the stress acts on the initial volume (sigma V = sigma V0): the solver
    #: then leaves V_p alone
    initial_volume = False
    #: the dimensions the law is written for
    dims = (1, 2, 3)
    #: True where the law lets a particle expand without bound (a tension cut-off: fluids,
    #: sand); the solver's volume guard then bounds only its compaction
    free_expansion = False
    #: the law has a stored energy W(F): ``energy(s, p)`` gives W(F_p) V0_p
    energy_function = False
    #: the stress is a function of F alone: ``stress(s, p, F)`` gives sigma(F)
    stress_from_F = False
    #: the law may be a saturated soil's skeleton (a body with pore water: the law then
    #: acts on the effective stress, timpm.materials.pore_water)
    carries_pore_water = False

    def __init__(self, density):
        self.density = self.checked("density", density)

    def speed_of(self, modulus: str, value: float) -> float:
        """The wave speed sqrt(``value`` / density), ``value`` the modulus it comes from
        (parameter ``modulus``, or a combination of it): one a float cannot hold (a
        modulus near 1e308, a ratio that overflows or underflows to 0) is refused naming
        ``modulus``, as the CFL limit would turn it into a time step of 0 or NaN blamed on
        dt."""
        with_ratio = value / self.density if math.isfinite(value) else math.inf
        c = math.sqrt(with_ratio) if math.isfinite(with_ratio) else math.inf
        if not (math.isfinite(c) and c > 0.0):
            raise InputError(f"{self.name}: {modulus} = {getattr(self, modulus):g} with "
                             f"density = {self.density:g} gives a wave speed of {c:g} m/s, "
                             f"which the time step cannot follow (a float overflows or "
                             f"underflows): give {modulus} and density of physical size (SI "
                             f"units)", modulus)
        return c

    @classmethod
    def checked(cls, name: str, value):
        """``value`` of parameter ``name`` checked against its declaration (``PARAMS``)."""
        return cls.PARAMS[name].check(cls.name, name, value)

    def __repr__(self):
        params = ", ".join(f"{k}={v:g}" for k, v in self.parameters().items())
        return f"{type(self).__name__}({params})"

    def parameters(self) -> dict:
        return {"density": self.density}

    @classmethod
    def particle_fields(cls, dim: int) -> dict:
        """The particle state this law keeps besides stress and volume, in ``dim``
        dimensions: name -> Field."""
        return {}

    @classmethod
    def needs(cls, dim: int = 3) -> frozenset:
        """The names of :meth:`particle_fields`."""
        return frozenset(cls.particle_fields(dim))

    def flags(self) -> tuple:
        """Compile-time choices (hashable); the feature set holds (class, flags)."""
        return ()

    def constants(self, dt: float, h: float) -> dict:
        """Run-time constants by name (``CONSTANTS``) for a run with time step ``dt`` on a
        grid of spacing ``h`` (a law regularised by the cell size reads it)."""
        return {"density": self.density}

    @classmethod
    def unit(cls, flags: tuple, constants):
        """The compiled unit: an instance that holds no value, only ``flags`` and the
        getters of its constants (a :class:`timpm.engine.params.Params`)."""
        unit = object.__new__(cls)
        unit.c = constants
        unit.set_flags(flags)
        unit.stores_energy = cls.has_energy_function(flags)  # what the records read
        return unit

    def set_flags(self, flags: tuple):
        """Set the compile-time attributes of a unit from ``flags()``."""

    @classmethod
    def has_energy_function(cls, flags: tuple) -> bool:
        """Whether the law compiled with ``flags`` has a stored energy W(F)
        (``energy_function``, unless a flag decides it)."""
        return cls.energy_function

    @ti.func
    def reference_volume(self, s: ti.template(), p):
        """V0_p = m_p / density."""
        return s.m[p] / self.c.density()

    @ti.func
    def strain_energy(self, s: ti.template(), p):
        """The particle's strain energy: W(F_p) V0_p where the law has a stored energy,
        else the work sigma : d_eps V the engine integrates along its path (``s.work``)."""
        energy = 0.0
        if ti.static(self.stores_energy):
            energy = self.energy(s, p)
        else:
            energy = s.work[p]
        return energy

    @ti.func
    def volume_in_range(self, s: ti.template(), p, vol, lowest, highest):
        """lowest <= V_p / V0 <= highest (the volume guard), V0 = m_p / density; a law
        that lets a particle expand freely has no upper bound."""
        ratio = vol * self.c.density() / s.m[p]
        ok = ratio >= lowest
        if ti.static(not self.free_expansion):
            ok = ok and ratio <= highest
        return ok

    @ti.func
    def _initial_over_current_volume(self, s: ti.template(), p):
        """V0 / V_p: Cauchy stress = Kirchhoff stress times this."""
        return s.m[p] / self.c.density() / s.vol[p]


class SolidMaterial(Material):
    """Isotropic elastic constants from Young's modulus and Poisson's ratio."""

    carries_pore_water = True

    CONSTANTS = ("density", "mu", "lam", "two_mu")

    PARAMS = {**Material.PARAMS,
              "E": Param(unit="Pa", doc="Young's modulus", low=0.0, low_open=True),
              "nu": Param(doc="Poisson's ratio; 0.5 is incompressible: use a fluid or a "
                              "smaller ratio", low=-1.0, high=0.5, low_open=True,
                          high_open=True)}

    def __init__(self, E, nu, density):
        super().__init__(density)
        self.E = self.checked("E", E)
        self.nu = nu = self.checked("nu", nu)
        self.mu = self.E / (2.0 * (1.0 + nu))
        self.lam = self.E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        # P-wave speed sqrt((lambda + 2 mu) / rho)
        self.wave_speed = self.speed_of("E", self.lam + 2.0 * self.mu)

    def parameters(self) -> dict:
        return {"E": self.E, "nu": self.nu, "density": self.density}

    @classmethod
    def particle_fields(cls, dim):
        return {"F": Field("matrix", initial="identity",
                           doc="the (elastic) deformation gradient")}

    def constants(self, dt: float, h: float) -> dict:
        return {"density": self.density, "mu": self.mu, "lam": self.lam,
                "two_mu": 2.0 * self.mu}

    def initial_state(self, stress, dim) -> dict:
        """The state this law's fields start from under the Cauchy ``stress`` (m, 3, 3) in
        the reference configuration (V = V0): how a scene starts from an initial stress;
        name -> array (m, ...), e.g. the elastic deformation gradients ``F`` (m, dim, dim)
        of a Hencky law (its out-of-plane elastic log strain ``ezz`` in plane strain where
        it keeps one).  Laws with a Hencky elastic part give it; the others refuse."""
        raise ValueError(f"{self.name}: an initial stress is set through the elastic strain "
                         "of a Hencky law (drucker-prager, mohr-coulomb); this law has none")

    def _hencky_state(self, stress, dim, plane_trace=False):
        """Hencky's inverse, eps = (tau - lam tr(eps) I) / (2 mu), tau = sigma (V = V0), as
        F_e = Q exp(eps) Q^T; ``plane_trace``: a 2D law whose trace is the in-plane one."""
        import numpy as np

        stress = np.asarray(stress, dtype=np.float64)
        if dim == 2 and np.any(stress[:, :2, 2] != 0.0):
            raise ValueError(f"{self.name}: an initial stress in plane strain has no xz or "
                             "yz shear")
        if dim == 2 and plane_trace:
            tau = stress[:, :2, :2]
            trace_eps = np.trace(tau, axis1=1, axis2=2) / (2.0 * self.lam + 2.0 * self.mu)
        else:
            tau = stress  # 3x3: in 2D with sigma_zz, the plane-strain law's ezz
            trace_eps = np.trace(stress, axis1=1, axis2=2) / (3.0 * self.lam + 2.0 * self.mu)
        eye = np.eye(tau.shape[1])
        eps = (tau - self.lam * trace_eps[:, None, None] * eye) / (2.0 * self.mu)
        w, Q = np.linalg.eigh(eps[:, :dim, :dim])
        worst = np.abs(eps).max(axis=(1, 2)) if len(eps) else np.zeros(0)
        if len(worst) and not worst.max() <= MAX_INITIAL_LOG_STRAIN:
            k = int(np.argmax(worst))
            raise ValueError(f"{self.name}: the initial stress ({np.abs(stress[k]).max():.3g} "
                             f"Pa at its largest) needs an elastic log strain of "
                             f"{worst[k]:.3g} (stress / E, E = {self.E:g} Pa), beyond the "
                             f"{MAX_INITIAL_LOG_STRAIN:g} a Hencky law is started from (a "
                             f"stretch of e^{MAX_INITIAL_LOG_STRAIN:g}): stiffen the soil (E) "
                             "or start it from a smaller stress")
        F = np.einsum("nij,nj,nkj->nik", Q, np.exp(w), Q)
        ezz = eps[:, 2, 2] if dim == 2 and not plane_trace else np.zeros(len(eps))
        return F, ezz

    def _tensile_strength(self, value, apex):
        """A soil's tension cut-off: None (at the apex of its surface) or a stress in [0,
        apex] (Pa), checked."""
        if value is None:
            return None
        try:
            st = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"{self.name}: tensile_strength must be a number (Pa) or None, "
                             f"got {value!r}") from None
        if not (0.0 <= st <= apex):
            raise ValueError(f"{self.name}: tensile_strength must lie in [0, c cot(phi) = "
                             f"{apex:g}] Pa (the apex of the surface), got {value!r}")
        return st

    @ti.func
    def _trial_F(self, s: ti.template(), p, grad_du):
        """F_trial = (I + grad du) F_p: the deformation gradient advanced by the step."""
        return (ti.Matrix.identity(float, s.dim) + grad_du) @ s.F[p]

    @ti.func
    def _principal_log_strains(self, s: ti.template(), F, n: ti.template()):
        """F = U diag(S) V^T: U, V and the logarithms of S as the first ``s.dim`` of ``n``
        entries (n > dim: room for a plane-strain law's out-of-plane strain)."""
        U, S, V = svd(F)  # (not ti.svd: it drops shears under 1e-5, materials/svd.py)
        eps = ti.Vector.zero(float, n)
        for k in ti.static(range(s.dim)):
            eps[k] = ti.log(ti.max(ti.abs(S[k, k]), 1e-12))
        return U, eps, V

    @ti.func
    def _hencky_stress(self, s: ti.template(), p, U, V, eps, tr):
        """The elastic state F_e = U diag(exp(eps)) V^T stored in ``s.F[p]``, and the Cauchy
        stress of the principal Kirchhoff stresses 2 mu eps_k + lam tr (``tr``: the law's
        trace of eps), U diag(tau) U^T V0 / V."""
        d = ti.static(s.dim)
        Se = ti.Matrix.zero(float, d, d)
        T = ti.Matrix.zero(float, d, d)
        for k in ti.static(range(d)):
            Se[k, k] = ti.exp(eps[k])
            T[k, k] = self.c.two_mu() * eps[k] + self.c.lam() * tr
        s.F[p] = U @ Se @ V.transpose()
        return U @ T @ U.transpose() * self._initial_over_current_volume(s, p)
