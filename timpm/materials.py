"""Constitutive models: each a small compiled unit that a scene includes only if it uses it.

A material is a ``@ti.data_oriented`` object of compile-time constants with one
``@ti.func``::

    sigma_new = material.update(solver, p, grad_du, sigma_old)

called in G2P with the displacement-increment gradient ``grad_du = sum_i u_i^inc
grad(phi_i)^T`` of particle ``p`` (so ``I + grad_du`` is the incremental deformation
gradient), after the solver has stored the particle's new volume in ``solver.vol[p]``.
It advances the particle state the material owns (``needs``: the deformation gradient
``F``, the plastic strain ``plastic``) and returns the new Cauchy stress.  The solver allocates a state field only when a material of the scene needs it
and compiles only the update functions of the scene's materials.

Materials for multi-dimensional scenes: :class:`LinearElastic`, :class:`NeoHookean`,
:class:`DruckerPrager` (sand, return mapping of Klar et al. 2016) and
:class:`WeaklyCompressibleFluid` (Tait equation of state).  :class:`Hypoelastic1D` is the
study's 1D law, built by the solver from a 1D :class:`timpm.scene.Material`.
"""

import math

import taichi as ti

from .scene import _positive

__all__ = ["SolidMaterial", "LinearElastic", "NeoHookean", "DruckerPrager",
           "WeaklyCompressibleFluid", "JFluid", "Hypoelastic1D", "MATERIALS", "get_material"]


@ti.data_oriented
class Material:
    """Common interface: ``density``, ``wave_speed`` (for the CFL limit), ``needs``."""

    name = ""
    #: particle state this material keeps, besides stress and volume
    needs = frozenset()

    #: wave speed (m/s) that bounds the time step, set by each material
    wave_speed = 0.0

    #: True where the stress acts on the initial volume (sigma V = sigma V0): the solver
    #: then leaves V_p alone
    initial_volume = False

    def __init__(self, density):
        self.density = _positive(f"{self.name}: density", density)

    def __repr__(self):
        params = ", ".join(f"{k}={v:g}" for k, v in self.parameters().items())
        return f"{type(self).__name__}({params})"

    def parameters(self) -> dict:
        return {"density": self.density}

    @ti.func
    def _initial_over_current_volume(self, s: ti.template(), p):
        """V0 / V_p: Cauchy stress = Kirchhoff stress times this."""
        return s.m[p] / self.density / s.vol[p]


class SolidMaterial(Material):
    """Isotropic elastic constants from Young's modulus and Poisson's ratio."""

    needs = frozenset({"F"})

    def __init__(self, E, nu, density):
        super().__init__(density)
        self.E = _positive(f"{self.name}: Young's modulus E", E)
        try:
            nu = float(nu)
        except (TypeError, ValueError):
            raise ValueError(f"{self.name}: Poisson's ratio must be a number, got {nu!r}") from None
        if not (-1.0 < nu < 0.5):
            raise ValueError(f"{self.name}: Poisson's ratio must lie in (-1, 0.5), got {nu!r} "
                             "(0.5 is incompressible: use a fluid or a smaller ratio)")
        self.nu = nu
        self.mu = self.E / (2.0 * (1.0 + nu))
        self.lam = self.E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        # P-wave speed sqrt((lambda + 2 mu) / rho)
        self.wave_speed = math.sqrt((self.lam + 2.0 * self.mu) / self.density)

    def parameters(self) -> dict:
        return {"E": self.E, "nu": self.nu, "density": self.density}

    @ti.func
    def _trial_F(self, s: ti.template(), p, grad_du):
        """F_trial = (I + grad du) F_p: the deformation gradient advanced by the step."""
        return (ti.Matrix.identity(float, s.dim) + grad_du) @ s.F[p]


class LinearElastic(SolidMaterial):
    """Small-strain linear elasticity: sigma = lambda tr(eps) I + 2 mu eps, eps = sym(F) - I."""

    name = "linear-elastic"

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        s.F[p] = F
        eps = 0.5 * (F + F.transpose()) - ti.Matrix.identity(float, s.dim)
        return self.lam * eps.trace() * ti.Matrix.identity(float, s.dim) + 2.0 * self.mu * eps


class NeoHookean(SolidMaterial):
    """Compressible Neo-Hookean solid: sigma = (mu (F F^T - I) + lambda ln J I) / J."""

    name = "neo-hookean"

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        s.F[p] = F
        J = F.determinant()
        eye = ti.Matrix.identity(float, s.dim)
        return (self.mu * (F @ F.transpose() - eye) + self.lam * ti.log(J) * eye) / J


class DruckerPrager(SolidMaterial):
    """Cohesionless Drucker-Prager sand (Klar et al. 2016): Hencky elasticity with a
    return mapping of the principal logarithmic strains onto the cone, tension cut off.

    ``F`` holds the elastic deformation gradient, ``plastic`` the accumulated plastic
    strain |d gamma| (for colouring and post-processing).
    """

    name = "drucker-prager"
    needs = frozenset({"F", "plastic"})

    def __init__(self, E, nu, density, friction_angle):
        super().__init__(E, nu, density)
        try:
            phi = float(friction_angle)
        except (TypeError, ValueError):
            raise ValueError(f"{self.name}: friction angle must be a number of degrees, got "
                             f"{friction_angle!r}") from None
        if not (0.0 < phi < 90.0):
            raise ValueError(f"{self.name}: friction angle must lie in (0, 90) degrees, got "
                             f"{friction_angle!r}")
        self.friction_angle = phi
        sin_phi = math.sin(math.radians(phi))
        # cone coefficient of Klar et al. (2016), Eq. 27
        self.alpha = math.sqrt(2.0 / 3.0) * 2.0 * sin_phi / (3.0 - sin_phi)

    def parameters(self) -> dict:
        return {**super().parameters(), "friction_angle": self.friction_angle}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        sig = ti.Matrix.zero(float, s.dim, s.dim)
        if ti.static(s.dim == 2):
            sig = self._update_2d(s, p, F)
        else:
            sig = self._update_svd(s, p, F)
        return sig

    @ti.func
    def _update_2d(self, s: ti.template(), p, F):
        """The same return mapping in 2D from the spectral form of b = F F^T, no SVD: with
        b's eigenvalues l1 >= l2 and A = (b - m I) / r (m, r: mean and half gap), a
        function of b is f(b) = (f1 + f2) / 2 I + (f1 - f2) / 2 A (about 2x faster)."""
        eye = ti.Matrix.identity(float, 2)
        b = F @ F.transpose()
        m = 0.5 * (b[0, 0] + b[1, 1])
        r = ti.sqrt(0.25 * (b[0, 0] - b[1, 1]) ** 2 + b[0, 1] ** 2)
        l1 = m + r
        l2 = ti.max(b.determinant(), 1e-24) / ti.max(l1, 1e-12)  # m - r without cancellation
        A = ti.Matrix.zero(float, 2, 2)
        if r > 1e-14 * m:
            A = (b - m * eye) / r
        e1 = 0.5 * ti.log(ti.max(l1, 1e-24))  # principal Hencky strains, e1 >= e2
        e2 = 0.5 * ti.log(l2)
        # return mapping (Klar et al. 2016, Alg. 2); in 2D the deviatoric direction of
        # (e1, e2) is (1, -1) / sqrt 2, so the plastic correction scales b's eigenvectors by
        # exp(-+ dgamma / sqrt 2)
        tr = e1 + e2
        dgamma = 0.0
        g1, g2 = 1.0, 1.0  # exp(e_new - e) along each eigenvector
        if tr >= 0.0:  # tension: back to the cone tip
            dgamma = ti.sqrt(e1 * e1 + e2 * e2)
            e1, e2 = 0.0, 0.0
            g1, g2 = 1.0 / ti.sqrt(ti.max(l1, 1e-24)), 1.0 / ti.sqrt(l2)
        else:
            dev_norm = (e1 - e2) / ti.sqrt(2.0)
            dgamma = dev_norm + (2.0 * self.lam + 2.0 * self.mu) / (2.0 * self.mu) * tr * self.alpha
            if dgamma > 0.0:
                shift = dgamma / ti.sqrt(2.0)
                e1 -= shift
                e2 += shift
                g1 = ti.exp(-shift)
                g2 = 1.0 / g1
            else:
                dgamma = 0.0
        s._sum_into(s.plastic[p], dgamma)
        if dgamma > 0.0:  # plastic: the elastic part moves back onto the cone
            F = (0.5 * (g1 + g2) * eye + 0.5 * (g1 - g2) * A) @ F
        s.F[p] = F
        tr_e = e1 + e2
        tau1 = 2.0 * self.mu * e1 + self.lam * tr_e
        tau2 = 2.0 * self.mu * e2 + self.lam * tr_e
        T = 0.5 * (tau1 + tau2) * eye + 0.5 * (tau1 - tau2) * A
        return T * self._initial_over_current_volume(s, p)

    @ti.func
    def _update_svd(self, s: ti.template(), p, F):
        d = ti.static(s.dim)
        U, S, V = ti.svd(F)
        eps = ti.Vector.zero(float, d)
        for k in ti.static(range(d)):
            eps[k] = ti.log(ti.max(ti.abs(S[k, k]), 1e-12))
        # return mapping on the principal Hencky strains (Klar et al. 2016, Alg. 2)
        tr = eps.sum()
        dev = eps - tr / d
        dev_norm = dev.norm()
        dgamma = 0.0
        if tr >= 0.0:  # tension: cohesionless sand carries none, back to the cone tip
            dgamma = eps.norm()
            eps = ti.Vector.zero(float, d)
        else:
            dgamma = dev_norm + (d * self.lam + 2.0 * self.mu) / (2.0 * self.mu) * tr * self.alpha
            if dgamma > 0.0:
                eps -= dgamma / dev_norm * dev
            else:
                dgamma = 0.0
        s._sum_into(s.plastic[p], dgamma)
        tau = ti.Vector.zero(float, d)
        tr_e = eps.sum()
        for k in ti.static(range(d)):
            tau[k] = 2.0 * self.mu * eps[k] + self.lam * tr_e
        if dgamma > 0.0:  # plastic: the elastic part moves back onto the cone
            Se = ti.Matrix.zero(float, d, d)
            for k in ti.static(range(d)):
                Se[k, k] = ti.exp(eps[k])
            F = U @ Se @ V.transpose()
        s.F[p] = F
        # Kirchhoff stress U diag(tau) U^T; Cauchy stress = tau V0 / V (the solver's volume
        # follows the total deformation, V = V0 det F_total)
        T = ti.Matrix.zero(float, d, d)
        for k in ti.static(range(d)):
            T[k, k] = tau[k]
        return U @ T @ U.transpose() * self._initial_over_current_volume(s, p)


class WeaklyCompressibleFluid(Material):
    """Tait fluid: p = K / gamma (J^-gamma - 1), sigma = -p I + 2 mu_visc sym(grad v).

    J = V / V0 comes from the particle volume, so the fluid keeps no extra state.  With
    ``tension=False`` (default) the pressure is clipped at zero: free-surface particles
    do not pull on each other.
    """

    name = "fluid"

    def __init__(self, bulk_modulus, density, gamma=7.0, viscosity=0.0, tension=False):
        super().__init__(density)
        self.bulk_modulus = _positive(f"{self.name}: bulk modulus", bulk_modulus)
        self.gamma = _positive(f"{self.name}: Tait exponent gamma", gamma)
        try:
            viscosity = float(viscosity)
        except (TypeError, ValueError):
            viscosity = float("nan")
        if not (math.isfinite(viscosity) and viscosity >= 0.0):
            raise ValueError(f"{self.name}: viscosity must be a finite number >= 0, got "
                             f"{viscosity!r}")
        self.viscosity = viscosity
        self.tension = bool(tension)
        self.wave_speed = math.sqrt(self.bulk_modulus / self.density)

    def parameters(self) -> dict:
        return {"bulk_modulus": self.bulk_modulus, "density": self.density,
                "gamma": self.gamma, "viscosity": self.viscosity}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        d = ti.static(s.dim)
        eye = ti.Matrix.identity(float, d)
        J = s.vol[p] * self.density / s.m[p]
        pressure = self.bulk_modulus / self.gamma * (ti.pow(J, -self.gamma) - 1.0)
        if ti.static(not self.tension):
            pressure = ti.max(pressure, 0.0)
        sigma = -pressure * eye
        if ti.static(self.viscosity > 0.0):
            sigma += self.viscosity / s.dt * (grad_du + grad_du.transpose())
        return sigma


class JFluid(Material):
    """The fluid of Taichi's ``mpm88`` (Hu et al. 2018): J advances by its linearised rate,
    J <- J (1 + tr grad du), and the pressure K (1 - J) acts on the initial volume
    (sigma V = K (J - 1) V0 I).  Cheaper than :class:`WeaklyCompressibleFluid` and
    first-order in the step; here to run mpm88's physics side by side with it.  As in
    mpm88, a particle's volume stays V0 (J holds the volume ratio)."""

    name = "j-fluid"
    needs = frozenset({"J"})
    initial_volume = True

    def __init__(self, bulk_modulus, density):
        super().__init__(density)
        self.bulk_modulus = _positive(f"{self.name}: bulk modulus", bulk_modulus)
        self.wave_speed = math.sqrt(self.bulk_modulus / self.density)

    def parameters(self) -> dict:
        return {"bulk_modulus": self.bulk_modulus, "density": self.density}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        J = s.J[p] * (1.0 + grad_du.trace())
        s.J[p] = J
        scale = 1.0  # V = V0 alone: no division by a volume that a crushed particle drives to 0
        if ti.static(s.update_volume):  # mixed with materials whose volume changes
            scale = self._initial_over_current_volume(s, p)
        return (self.bulk_modulus * (J - 1.0) * scale) * ti.Matrix.identity(float, s.dim)


@ti.data_oriented
class Hypoelastic1D:
    """The study's 1D law (2.2.4): sigma += (E - sigma) d_eps, or sigma += E d_eps."""

    needs = frozenset({"eps"})
    initial_volume = False

    def __init__(self, E, study: bool):
        self.E, self.study = float(E), bool(study)

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        deps = 0.5 * (grad_du + grad_du.transpose())
        sig_new = sigma_old + self.E * deps
        if ti.static(self.study):
            sig_new = sigma_old + (self.E - sigma_old) * deps
        s._sum_into(s.eps[p], deps)
        return sig_new


MATERIALS = {cls.name: cls for cls in (LinearElastic, NeoHookean, DruckerPrager,
                                       WeaklyCompressibleFluid, JFluid)}


def get_material(name: str, **params) -> Material:
    """A material by name: ``get_material("neo-hookean", E=1e3, nu=0.3, density=1e3)``."""
    if name not in MATERIALS:
        raise ValueError(f"unknown material {name!r}: choose one of {', '.join(MATERIALS)}")
    try:
        return MATERIALS[name](**params)
    except TypeError as err:
        raise ValueError(f"material {name!r}: {err}") from None
