"""Mohr-Coulomb with strain softening: the cohesion and the friction angle fall with the
accumulated plastic shear strain to residual values, the softening regularised by the
cell size."""
import math

import taichi as ti

from ..platform.declare import Field, Param
from .mohr_coulomb import UNBOUNDED, MohrCoulomb, principal_return

__all__ = ["MohrCoulombSoftening"]


class MohrCoulombSoftening(MohrCoulomb):
    """:class:`MohrCoulomb` whose strength softens linearly with the accumulated plastic
    shear strain kappa = sum (d eps1_p - d eps3_p) (the engineering shear strain of the
    plane of the largest shear, each step's principal plastic log strains):

        zeta = max(0, 1 - kappa / kappa_r),
        c = c_r + zeta (c_p - c_r),  phi = phi_r + zeta (phi_p - phi_r),  psi = zeta psi_p,

    from the peak (``cohesion``, ``friction_angle``, ``dilation_angle``) to the residual
    (``residual_cohesion``, ``residual_friction_angle``; no dilation: a soil sheared to its
    residual has reached its critical state).  Where the strain localises it does so in a
    band about one cell wide, so a softening written in strain would soften over a
    displacement that shrinks with the cell: the law takes the displacement across the
    band instead, ``softening_displacement`` u_r, and softens over kappa_r = u_r / h on a
    grid of spacing h (the band's dissipation then does not depend on h; Wang, Vardon and
    Hicks 2016 regularised the retrogressive failures of sensitive clay slopes alike).

    The return of each step goes to the surface of the kappa it ends at (backward Euler in
    kappa: the stress lies on the surface of its own kappa, whatever the step), found by
    secant steps on kappa; a tension cut-off (``tensile_strength``) stays at most the apex
    c cot(phi) of the softened surface.  Where the softening is steeper than the elastic
    unloading (kappa_r below about (c_p - c_r) / mu: a brittle point on a fine grid) the
    return has no unique answer and the iteration stops after MAX_ITERATIONS returns.  ``kappa`` is the law's own particle field, beside the elastic F, ``ezz``
    (plane strain) and ``plastic`` of :class:`MohrCoulomb`.
    """

    name = "mohr-coulomb-softening"
    CONSTANTS = MohrCoulomb.CONSTANTS + ("cohesion", "residual_cohesion", "phi", "residual_phi",
                                         "psi", "kappa_r", "tension_cap")

    PARAMS = {**MohrCoulomb.PARAMS,
              "residual_cohesion": Param(unit="Pa", doc="c_r, the cohesion once softened, at "
                                         "most the cohesion", low=0.0),
              "residual_friction_angle": Param(unit="degrees", doc="phi_r, the friction angle "
                                               "once softened, at most the friction angle "
                                               "(none: the friction angle)", low=0.0,
                                               high=90.0, high_open=True, optional=True),
              "softening_displacement": Param(unit="m", doc="u_r, the plastic shear "
                                              "displacement across a band one cell wide "
                                              "over which the strength falls to the "
                                              "residual (kappa_r = u_r / h)", low=0.0,
                                              low_open=True)}

    def __init__(self, E, nu, density, friction_angle, cohesion=0.0, dilation_angle=0.0,
                 tensile_strength=None, *, softening_displacement, residual_cohesion=0.0,
                 residual_friction_angle=None):
        super().__init__(E, nu, density, friction_angle, cohesion, dilation_angle,
                         tensile_strength)
        c_r = self.checked("residual_cohesion", residual_cohesion)
        phi_r = self.checked("residual_friction_angle", residual_friction_angle)
        phi_r = self.friction_angle if phi_r is None else phi_r
        if c_r > self.cohesion:
            raise ValueError(f"{self.name}: residual_cohesion {c_r:g} Pa must not exceed the "
                             f"cohesion {self.cohesion:g} Pa (a soil softens)")
        if phi_r > self.friction_angle:
            raise ValueError(f"{self.name}: residual_friction_angle {phi_r:g} must not exceed "
                             f"the friction_angle {self.friction_angle:g} (a soil softens)")
        if phi_r == 0.0 and c_r == 0.0:
            raise ValueError(f"{self.name}: a residual soil with neither friction nor "
                             "cohesion has no strength: give residual_friction_angle > 0 or "
                             "residual_cohesion > 0")
        self.residual_cohesion, self.residual_friction_angle = c_r, phi_r
        self.softening_displacement = self.checked("softening_displacement",
                                                   softening_displacement)

    @classmethod
    def particle_fields(cls, dim):
        return {**super().particle_fields(dim),
                "kappa": Field(doc="the accumulated plastic shear strain sum (d eps1_p - "
                                   "d eps3_p), which softens the strength")}

    def parameters(self) -> dict:
        return {**super().parameters(), "residual_cohesion": self.residual_cohesion,
                "residual_friction_angle": self.residual_friction_angle,
                "softening_displacement": self.softening_displacement}

    def constants(self, dt: float, h: float) -> dict:
        st = self.tensile_strength
        return {**super().constants(dt, h), "cohesion": self.cohesion,
                "residual_cohesion": self.residual_cohesion,
                "phi": math.radians(self.friction_angle),
                "residual_phi": math.radians(self.residual_friction_angle),
                "psi": math.radians(self.dilation_angle),
                "kappa_r": self.softening_displacement / h,
                "tension_cap": UNBOUNDED if st is None else st}

    # ---- the softening path in closed form --------------------------------------------
    def softened(self, kappa: float, h: float = 1.0) -> MohrCoulomb:
        """The perfectly plastic soil of the surface at plastic shear strain ``kappa`` on a
        grid of spacing ``h``: c, phi and psi softened, the elastic constants kept."""
        zeta = max(0.0, 1.0 - float(kappa) * h / self.softening_displacement)
        c = self.residual_cohesion + zeta * (self.cohesion - self.residual_cohesion)
        phi = self.residual_friction_angle + zeta * (self.friction_angle
                                                     - self.residual_friction_angle)
        st = self.tensile_strength
        if st is not None and phi > 0.0:  # at most the softened surface's apex
            st = min(st, c * math.cos(math.radians(phi)) / math.sin(math.radians(phi)))
        return MohrCoulomb(E=self.E, nu=self.nu, density=self.density, friction_angle=phi,
                           cohesion=c, dilation_angle=zeta * self.dilation_angle,
                           tensile_strength=st)

    def deviator(self, kappa: float, confinement: float, h: float = 1.0) -> float:
        """The deviator sigma_1 - sigma_3 the soil carries in compression under the
        confining pressure ``confinement`` once sheared to ``kappa``: the closed form of
        the softened surface (:meth:`MohrCoulomb.peak_deviator` of :meth:`softened`)."""
        return self.softened(kappa, h).peak_deviator(confinement)

    def residual_deviator(self, confinement: float) -> float:
        """The deviator at failure once fully softened."""
        return self.deviator(math.inf, confinement)

    def reduced(self, F: float) -> "MohrCoulombSoftening":
        """This soil with its peak and residual strengths divided by ``F`` (c / F, tan(phi)
        / F; strength reduction), the softening displacement and elastic constants kept."""
        base = super().reduced(F)
        phi_r = math.degrees(math.atan(math.tan(math.radians(self.residual_friction_angle))
                                       / float(F)))
        st = base.tensile_strength
        return MohrCoulombSoftening(
            E=self.E, nu=self.nu, density=self.density, friction_angle=base.friction_angle,
            cohesion=base.cohesion, dilation_angle=base.dilation_angle, tensile_strength=st,
            softening_displacement=self.softening_displacement,
            residual_cohesion=self.residual_cohesion / float(F), residual_friction_angle=phi_r)

    # ---- the compiled law ---------------------------------------------------------------
    @ti.func
    def surface(self, kappa):
        """The softened surface at plastic shear strain ``kappa``: (sin phi, sin psi,
        2 c cos phi, the apex c cot phi, the tension cut-off)."""
        # c, phi, psi from peak to residual linearly in zeta = max(0, 1 - kappa / kappa_r);
        # the apex c cot(phi) and the tension cut-off below it follow
        zeta = ti.max(0.0, 1.0 - kappa / self.c.kappa_r())
        c = self.c.residual_cohesion() + zeta * (self.c.cohesion() - self.c.residual_cohesion())
        phi = self.c.residual_phi() + zeta * (self.c.phi() - self.c.residual_phi())
        sin_phi = ti.sin(phi)
        apex = UNBOUNDED
        if sin_phi > 0.0:
            apex = c * ti.cos(phi) / sin_phi
        return (sin_phi, ti.sin(zeta * self.c.psi()), 2.0 * c * ti.cos(phi), apex,
                ti.min(self.c.tension_cap(), apex))

    @ti.func
    def strength(self, s: ti.template(), p):
        return self.surface(s.kappa[p])

    @ti.func
    def returned(self, s: ti.template(), p, eps):
        # the return to the surface of the kappa the step ends at (backward Euler in kappa):
        # g(k) = kappa_n + d_kappa(return to the surface of k) - k = 0, from k = kappa_n (g
        # = the explicit step's d_kappa >= 0; 0: elastic, one return), then a fixed-point
        # step and secant steps; d_kappa = d eps1_p - d eps3_p of the return
        k0 = s.kappa[p]
        k, k_prev, g_prev = k0, k0, 0.0
        tol = self.c.kappa_r() * ti.static(_tolerance())
        eps_new = eps
        for it in range(MAX_ITERATIONS):
            sin_phi, sin_psi, two_c_cos_phi, apex, tension = self.surface(k)
            eps_new = principal_return(eps, self.c.lam(), self.c.two_mu(), self.c.bulk3(),
                                       sin_phi, sin_psi, two_c_cos_phi, apex, tension)
            plastic = eps - eps_new
            g = k0 + plastic.max() - plastic.min() - k
            if ti.abs(g) <= tol:
                break
            k_next = k + g
            if it > 0 and g != g_prev:
                k_next = k - g * (k - k_prev) / (g - g_prev)
            k_prev, g_prev = k, g
            k = ti.max(k_next, k0)
        return eps_new

    @ti.func
    def after_return(self, s: ti.template(), p, plastic):
        # kappa += d eps1_p - d eps3_p: the largest less the smallest principal plastic log
        # strain of the step (the return's: kappa ends where its surface is)
        s.accumulate(s.kappa[p], plastic.max() - plastic.min())


#: the most returns a step of one particle takes to find the kappa it ends at (the secant
#: converges in a few where the softening is less steep than the elastic unloading)
MAX_ITERATIONS = 12


def _tolerance():
    """g(k) = 0 to this share of kappa_r: the precision's round-off, well above it."""
    from ..platform import runtime

    return 1e-12 if runtime.precision() == "f64" else 1e-5
