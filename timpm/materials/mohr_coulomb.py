"""Mohr-Coulomb soil: cohesion, friction, dilatancy and a tension cut-off, at large strains."""
import math

import numpy as np
import taichi as ti

from ..platform.declare import Field, Param
from .base import SolidMaterial
from .svd import principal_log_stretch, spectral

__all__ = ["MohrCoulomb", "principal_return"]

#: where the strength has no apex (phi = 0: Tresca) or no tension cut-off: a stress no
#: soil reaches
UNBOUNDED = 1e300


class MohrCoulomb(SolidMaterial):
    """Mohr-Coulomb perfect plasticity with Hencky elasticity (de Souza Neto, Peric and
    Owen 2008, 8.2.2 and 14: the return mapping in principal stresses, at large strains
    through the exponential map of the elastic left stretch).

    Yield surface (tension positive, principal Kirchhoff stresses t1 >= t2 >= t3):
    ``f = (t1 - t3) + (t1 + t3) sin(phi) - 2 c cos(phi)``; flow along the plastic potential
    with the dilation angle psi in place of phi (non-associated for psi < phi; psi = 0:
    no volume change in plastic flow).  The return goes to the surface's main plane, to
    one of its two edges (triaxial compression t1 = t2, extension t2 = t3), or to the
    apex t = c cot(phi); a tension cut-off (``tensile_strength``) then returns the
    principal stresses above it (Rankine planes, one to three).  The Kirchhoff stress is
    isotropic linear in the principal logarithmic elastic strains, so the small-strain
    algorithm applies to them unchanged; Cauchy stress = Kirchhoff stress V0 / V.

    ``F`` holds the elastic deformation gradient; in 2D (plane strain) ``ezz`` the
    out-of-plane elastic logarithmic strain (the total out-of-plane stretch stays 1, its
    plastic part moves where sigma_zz is the major or minor stress); ``plastic`` the
    accumulated norm of the deviatoric plastic strain increments.
    """

    name = "mohr-coulomb"
    CONSTANTS = SolidMaterial.CONSTANTS + ("sin_phi", "sin_psi", "two_c_cos_phi", "apex",
                                           "tension", "bulk3")
    dims = (2, 3)
    free_expansion = True  # beyond the tension cut-off a particle expands stress-free

    PARAMS = {**SolidMaterial.PARAMS,
              "friction_angle": Param(unit="degrees", doc="friction angle phi", low=0.0,
                                      high=90.0, high_open=True),
              "cohesion": Param(unit="Pa", doc="cohesion c", low=0.0),
              "dilation_angle": Param(unit="degrees", doc="dilation angle psi, at most phi",
                                      low=0.0, high=90.0, high_open=True),
              "tensile_strength": Param(unit="Pa", doc="tension cut-off (none: the apex, c "
                                        "cot phi)", low=0.0, optional=True)}

    def __init__(self, E, nu, density, friction_angle, cohesion=0.0, dilation_angle=0.0,
                 tensile_strength=None):
        super().__init__(E, nu, density)
        phi = self.checked("friction_angle", friction_angle)
        psi = self.checked("dilation_angle", dilation_angle)
        if psi > phi:
            raise ValueError(f"mohr-coulomb: dilation_angle {psi:g} must not exceed the "
                             f"friction_angle {phi:g} (a soil dilates at most as it rubs)")
        c = self.checked("cohesion", cohesion)
        if phi == 0.0 and c == 0.0:
            raise ValueError("mohr-coulomb: a soil with neither friction nor cohesion has no "
                             "strength: give friction_angle > 0 or cohesion > 0")
        self.friction_angle, self.dilation_angle, self.cohesion = phi, psi, c
        sin_phi = math.sin(math.radians(phi))
        # the apex of the surface, t1 = t2 = t3 = c cot(phi): the most tension it carries
        self.apex = c * math.cos(math.radians(phi)) / sin_phi if phi > 0.0 else UNBOUNDED
        self.tensile_strength = self._tensile_strength(
            self.checked("tensile_strength", tensile_strength), self.apex)

    @classmethod
    def particle_fields(cls, dim):
        fields = dict(super().particle_fields(dim))  # F, the elastic deformation gradient
        if dim == 2:
            fields["ezz"] = Field(doc="the out-of-plane elastic log strain (plane strain)")
        fields["plastic"] = Field(doc="the accumulated norm of the deviatoric plastic strain "
                                      "increments")
        return fields

    def parameters(self) -> dict:
        out = {**super().parameters(), "friction_angle": self.friction_angle,
               "cohesion": self.cohesion, "dilation_angle": self.dilation_angle}
        if self.tensile_strength is not None:
            out["tensile_strength"] = self.tensile_strength
        return out

    @property
    def two_c_cos_phi(self) -> float:
        """2 c cos(phi): the surface's intercept, (t1 - t3) + (t1 + t3) sin(phi) at yield."""
        return 2.0 * self.cohesion * math.cos(math.radians(self.friction_angle))

    def constants(self, dt: float, h: float) -> dict:
        phi, psi = math.radians(self.friction_angle), math.radians(self.dilation_angle)
        tension = self.apex if self.tensile_strength is None else self.tensile_strength
        return {**super().constants(dt, h), "sin_phi": math.sin(phi), "sin_psi": math.sin(psi),
                "two_c_cos_phi": self.two_c_cos_phi, "apex": self.apex,
                "tension": tension, "bulk3": 3.0 * self.lam + 2.0 * self.mu}

    def reduced(self, F: float) -> "MohrCoulomb":
        """This soil with its strength divided by ``F`` (strength reduction): c / F, tan(phi)
        / F, psi at most the reduced phi, the tension cut-off / F; the elastic constants
        kept."""
        F = float(F)
        if not (F > 0.0 and math.isfinite(F)):
            raise ValueError(f"{self.name}: a strength reduction factor must be positive, "
                             f"got {F!r}")
        phi = math.degrees(math.atan(math.tan(math.radians(self.friction_angle)) / F))
        st = self.tensile_strength
        out = MohrCoulomb(E=self.E, nu=self.nu, density=self.density, friction_angle=phi,
                          cohesion=self.cohesion / F,
                          dilation_angle=min(self.dilation_angle, phi),
                          tensile_strength=None if st is None else st / F)
        # what it was reduced from, and by: a random field's strength is reduced particle
        # by particle from its own values (model/random_field.py)
        out.unreduced, out.factor = self.unreduced, self.factor * F
        return out

    @property
    def unreduced(self) -> "MohrCoulomb":
        """The soil this one was reduced from (:meth:`reduced`; itself if it was not)."""
        return self.__dict__.get("_unreduced", self)

    @unreduced.setter
    def unreduced(self, soil):
        self.__dict__["_unreduced"] = soil

    @property
    def factor(self) -> float:
        """The factor its strength was divided by (:meth:`reduced`; 1 if it was not)."""
        return self.__dict__.get("_factor", 1.0)

    @factor.setter
    def factor(self, F):
        self.__dict__["_factor"] = float(F)

    def peak_deviator(self, confinement: float, dim: int = 3) -> float:
        """The deviator sigma_1 - sigma_3 at failure in compression under the confining
        pressure ``confinement`` (> 0, compression): the closed form of the surface,
        (2 c cos(phi) + 2 p sin(phi)) / (1 - sin(phi)).  Biaxial (plane strain, sigma_zz
        the intermediate stress) and triaxial compression alike."""
        s = math.sin(math.radians(self.friction_angle))
        return (self.two_c_cos_phi + 2.0 * confinement * s) / (1.0 - s)

    def yield_function(self, stress):
        """f of the Cauchy stresses (m, 3, 3) (<= 0: inside the surface), in Pa."""
        t = np.linalg.eigvalsh(np.asarray(stress, dtype=np.float64))  # ascending
        s = math.sin(math.radians(self.friction_angle))
        return (t[:, 2] - t[:, 0]) + (t[:, 2] + t[:, 0]) * s - self.two_c_cos_phi

    def initial_state(self, stress, dim):
        f = self.yield_function(stress)
        # round-off of a stress returned to the surface (a gravity loading's): 1e-9 of its
        # size, and a micro-pascal near the apex of a cohesionless soil
        scale = np.abs(np.asarray(stress)).max(axis=(1, 2)) + self.cohesion
        outside = np.flatnonzero(f > 1e-9 * scale + 1e-6)
        if len(outside):
            raise ValueError(f"{self.name}: the initial stress of {len(outside)} particle(s) "
                             f"lies outside the Mohr-Coulomb surface (the first, entry "
                             f"{int(outside[0])}: f = {f[outside[0]]:.4g} Pa > 0): raise K0 "
                             "toward 1 or the soil's strength")
        tension = self.apex if self.tensile_strength is None else self.tensile_strength
        top = np.linalg.eigvalsh(np.asarray(stress, dtype=np.float64))[:, 2]
        over = np.flatnonzero(top > tension * (1 + 1e-12) + 1e-6)
        if len(over):
            raise ValueError(f"{self.name}: the initial stress of {len(over)} particle(s) "
                             f"exceeds the tension cut-off {tension:g} Pa")
        F, ezz = self._hencky_state(stress, dim)
        return {"F": F, "ezz": ezz} if dim == 2 else {"F": F}

    @ti.func
    def strength(self, s: ti.template(), p):
        """The surface particle ``p`` returns to this step: (sin phi, sin psi, 2 c cos phi,
        the apex c cot phi, the tension cut-off), here the constants; a law whose strength
        follows a state of its own (softening) gives it from that state."""
        return (self.c.sin_phi(), self.c.sin_psi(), self.c.two_c_cos_phi(), self.c.apex(),
                self.c.tension())

    @ti.func
    def returned(self, s: ti.template(), p, eps):
        """The principal elastic log strains after the return of the trial ones ``eps`` to
        the surface of particle ``p`` (:meth:`strength`); a law whose surface moves with
        the plastic strain of the step (softening) returns to the surface it ends on."""
        sin_phi, sin_psi, two_c_cos_phi, apex, tension = self.strength(s, p)
        return principal_return(eps, self.c.lam(), self.c.two_mu(), self.c.bulk3(), sin_phi,
                                sin_psi, two_c_cos_phi, apex, tension)

    @ti.func
    def after_return(self, s: ti.template(), p, plastic):
        """Advance a state of the law's own from the step's principal plastic log strains
        ``plastic`` (any order); perfect plasticity keeps none."""
        pass

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        d = ti.static(s.dim)
        # the trial state: F_trial = (I + grad du) F_e, its principal elastic log strains
        # (of the left stretch) and their frame; [2]: zz in 2D
        F_trial = self._trial_F(s, p, grad_du)
        e, frame = principal_log_stretch(F_trial)
        eps = ti.Vector.zero(float, 3)
        for k in ti.static(range(d)):
            eps[k] = e[k]
        if ti.static(d == 2):
            eps[2] = s.ezz[p]
        eps_new = eps
        if self.elastic(s, p, eps):
            s.F[p] = F_trial  # inside the surface: the trial state is the elastic one
        else:
            # the return to the surface: eps_new, the step's plastic strain, and F_e =
            # U exp(eps_new) V^T = U exp(eps_new - eps) U^T F_trial
            eps_new = self.returned(s, p, eps)
            plastic = eps - eps_new
            dev = plastic - plastic.sum() / 3.0
            s.accumulate(s.plastic[p], dev.norm())
            self.after_return(s, p, plastic)
            if ti.static(d == 2):
                s.ezz[p] = eps_new[2]
            stretch = ti.Vector.zero(float, d)
            for k in ti.static(range(d)):
                stretch[k] = ti.exp(eps_new[k] - eps[k])
            s.F[p] = spectral(frame, stretch) @ F_trial
        # the Cauchy stress: the principal Kirchhoff stresses lam tr(eps) + 2 mu eps_k in
        # the frame, times V0 / V
        tau = self.c.lam() * eps_new.sum() + self.c.two_mu() * eps_new
        return spectral(frame, tau) * self._initial_over_current_volume(s, p)

    @ti.func
    def elastic(self, s: ti.template(), p, eps):
        """Whether the trial principal log strains ``eps`` lie inside the surface of
        particle ``p`` (:meth:`strength`) and below its tension cut-off: f <= 0 on the
        largest and the smallest principal Kirchhoff stress, as the return tests them."""
        sin_phi, sin_psi, two_c_cos_phi, apex, tension = self.strength(s, p)
        t = self.c.lam() * eps.sum() + self.c.two_mu() * eps
        t1 = ti.max(t[0], t[1], t[2])
        t3 = ti.min(t[0], t[1], t[2])
        return (t1 - t3) + (t1 + t3) * sin_phi - two_c_cos_phi <= 0.0 and t1 <= tension


@ti.func
def principal_return(eps, lam, two_mu, bulk3, sin_phi, sin_psi, two_c_cos_phi, apex,
                     tension):
    """The elastic principal log strains after the Mohr-Coulomb return and the tension
    cut-off, from the trial ones (any order; returned in the same order)."""
    # principal Kirchhoff stresses t = lam tr(eps) + 2 mu eps, sorted t1 >= t2 >= t3 by up
    # to three exchanges (undone at the end)
    e = eps
    t = lam * e.sum() + two_mu * e
    exchanged = ti.Vector([0, 0, 0])
    for k, i, j in ti.static(SORT):
        if t[i] < t[j]:
            ti_, ei = t[i], e[i]
            t[i], e[i] = t[j], e[j]
            t[j], e[j] = ti_, ei
            exchanged[k] = 1
    # the elastic matrix in principal axes: D = lam 1 1^T + 2 mu I
    D = lam * ti.Matrix([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]) \
        + two_mu * ti.Matrix.identity(float, 3)
    # the main plane (1, 3): gradient of f and of the potential g (psi for phi)
    nf_a = ti.Vector([1.0 + sin_phi, 0.0, -(1.0 - sin_phi)])
    ng_a = ti.Vector([1.0 + sin_psi, 0.0, -(1.0 - sin_psi)])
    f_a = (t[0] - t[2]) + (t[0] + t[2]) * sin_phi - two_c_cos_phi
    if f_a > 0.0:
        done = False
        # 1. the main plane: t - dg D n_g with f = 0
        dg = f_a / nf_a.dot(D @ ng_a)
        t_new = t - dg * (D @ ng_a)
        if t_new[0] >= t_new[1] and t_new[1] >= t_new[2]:
            e -= dg * ng_a
            done = True
        if not done:
            # 2. an edge: t1 = t2 (planes (1, 3) and (2, 3): triaxial compression, the
            # two larger stresses equal) where the main-plane return overshot t1 < t2,
            # else t2 = t3 (planes (1, 3) and (1, 2): triaxial extension)
            nf_b = ti.Vector([0.0, 1.0 + sin_phi, -(1.0 - sin_phi)])
            ng_b = ti.Vector([0.0, 1.0 + sin_psi, -(1.0 - sin_psi)])
            f_b = (t[1] - t[2]) + (t[1] + t[2]) * sin_phi - two_c_cos_phi
            if t_new[1] <= t_new[2]:
                nf_b = ti.Vector([1.0 + sin_phi, -(1.0 - sin_phi), 0.0])
                ng_b = ti.Vector([1.0 + sin_psi, -(1.0 - sin_psi), 0.0])
                f_b = (t[0] - t[1]) + (t[0] + t[1]) * sin_phi - two_c_cos_phi
            a11, a12 = nf_a.dot(D @ ng_a), nf_a.dot(D @ ng_b)
            a21, a22 = nf_b.dot(D @ ng_a), nf_b.dot(D @ ng_b)
            det = a11 * a22 - a12 * a21
            dga = (a22 * f_a - a12 * f_b) / det
            dgb = (a11 * f_b - a21 * f_a) / det
            t_new = t - D @ (dga * ng_a + dgb * ng_b)
            # (valid up to round-off: on a trial with two equal stresses, a symmetric
            # return, the edge is the answer, not the apex)
            slack = 1e-10 * (ti.abs(t[0]) + ti.abs(t[2]) + two_c_cos_phi)
            dg_slack = -1e-10 * ti.max(ti.abs(dga), ti.abs(dgb))
            if dga >= dg_slack and dgb >= dg_slack and t_new[0] + slack >= t_new[1] \
                    and t_new[1] + slack >= t_new[2]:
                e -= dga * ng_a + dgb * ng_b
                done = True
        if not done:
            # 3. the apex: t1 = t2 = t3 = c cot(phi), the elastic strain all volumetric
            e = ti.Vector([1.0, 1.0, 1.0]) * (apex / bulk3)
    # the tension cut-off (Rankine planes t_i = tension, i = 1..k), after the shear
    # return: it lowers f too, so both hold
    t = lam * e.sum() + two_mu * e
    if t[0] > tension:
        a, b = lam + two_mu, lam
        if t[2] > tension:
            e = ti.Vector([1.0, 1.0, 1.0]) * (tension / bulk3)
        else:
            d1 = (t[0] - tension) / a
            if t[1] - b * d1 > tension:  # two planes: [[a, b], [b, a]] d = t - tension
                r1, r2 = t[0] - tension, t[1] - tension
                d1 = (a * r1 - b * r2) / (a * a - b * b)
                d2 = (a * r2 - b * r1) / (a * a - b * b)
                e[0] -= d1
                e[1] -= d2
                if lam * e.sum() + two_mu * e[2] > tension:  # all three: the cut-off's apex
                    e = ti.Vector([1.0, 1.0, 1.0]) * (tension / bulk3)
            else:
                e[0] -= d1
    # back to the order of eps
    for k, i, j in ti.static(SORT[::-1]):
        if exchanged[k]:
            ei = e[i]
            e[i] = e[j]
            e[j] = ei
    return e


#: the exchanges that sort three values (step, i, j): (0, 1), (1, 2), (0, 1)
SORT = ((0, 0, 1), (1, 1, 2), (2, 0, 1))
