"""Drucker-Prager soil: sand (Klar et al. 2016), with cohesion, dilatancy and a tension
cut-off where given."""
import math

import taichi as ti

from ..platform.declare import Field, Param
from .base import SolidMaterial

__all__ = ["DruckerPrager"]


def _cone(angle):
    """The cone coefficient of Klar et al. (2016), Eq. 27, of a friction (or dilation)
    angle in degrees."""
    s = math.sin(math.radians(angle))
    return math.sqrt(2.0 / 3.0) * 2.0 * s / (3.0 - s)


class DruckerPrager(SolidMaterial):
    """Drucker-Prager soil (Klar et al. 2016): Hencky elasticity with a return mapping of
    the principal logarithmic strains onto the cone ||dev tau|| + alpha (tr tau - d p_a) <=
    0 (d: the law's dimension, 2 in plane strain), alpha from the friction angle.

    Cohesionless (the default) the apex is at p_a = 0 and tension is cut off there: the
    law of Klar et al. as it was.  With ``cohesion`` c the apex moves to the hydrostatic
    tension p_a = c cot(phi) (where Mohr-Coulomb's is); ``tensile_strength`` cuts the
    mean stress off below it; ``dilation_angle`` psi <= phi makes the flow non-associated:
    the plastic strain d gamma (n + alpha_psi I), alpha_psi the cone coefficient of psi.
    A return past the cone's apex goes to the apex (on the cut-off, zero deviator).

    ``F`` holds the elastic deformation gradient, ``plastic`` the accumulated plastic
    strain |d gamma| (for colouring and post-processing).
    """

    name = "drucker-prager"
    free_expansion = True  # beyond the cut-off a particle expands stress-free
    CONSTANTS = SolidMaterial.CONSTANTS + ("alpha", "cone_2d", "cone_3d", "alpha_psi",
                                           "apex_2d", "apex_3d", "cut_2d", "cut_3d")
    dims = (2, 3)  # the return mapping of principal strains: 2D spectral form, 3D SVD

    PARAMS = {**SolidMaterial.PARAMS,
              "friction_angle": Param(unit="degrees", doc="friction angle phi", low=0.0,
                                      high=90.0, low_open=True, high_open=True),
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
        c = self.checked("cohesion", cohesion)
        if psi > phi:
            raise ValueError(f"{self.name}: dilation_angle must lie in [0, friction_angle = "
                             f"{phi:g}] degrees, got {dilation_angle!r}")
        self.friction_angle, self.dilation_angle, self.cohesion = phi, psi, c
        self.alpha = _cone(phi)
        # the apex: the hydrostatic tension c cot(phi)
        self.apex = c / math.tan(math.radians(phi))
        self.tensile_strength = self._tensile_strength(
            self.checked("tensile_strength", tensile_strength), self.apex)
        # Klar et al.'s law exactly (compiled as before) unless one of these is given
        self.general = bool(c > 0.0 or psi > 0.0 or tensile_strength is not None)

    @classmethod
    def particle_fields(cls, dim):
        return {**super().particle_fields(dim),
                "plastic": Field(doc="the accumulated plastic strain")}

    def parameters(self) -> dict:
        out = {**super().parameters(), "friction_angle": self.friction_angle}
        if self.general:
            out.update(cohesion=self.cohesion, dilation_angle=self.dilation_angle)
            if self.tensile_strength is not None:
                out["tensile_strength"] = self.tensile_strength
        return out

    def flags(self) -> tuple:
        return ("general",) if self.general else ()  # () as before: old checkpoints fit

    def set_flags(self, flags: tuple):
        self.general = "general" in flags

    def constants(self, dt: float, h: float) -> dict:
        # (d lambda + 2 mu) / (2 mu): the trace's share of the return to the cone in d dims;
        # the apex and the cut-off as traces of the elastic log strain in d dims
        out = {**super().constants(dt, h), "alpha": self.alpha,
               "cone_2d": (2.0 * self.lam + 2.0 * self.mu) / (2.0 * self.mu),
               "cone_3d": (3 * self.lam + 2.0 * self.mu) / (2.0 * self.mu),
               "alpha_psi": _cone(self.dilation_angle) if self.dilation_angle > 0 else 0.0}
        cut = self.apex if self.tensile_strength is None else self.tensile_strength
        for d in (2, 3):
            k = d * self.lam + 2.0 * self.mu
            out[f"apex_{d}d"] = d * self.apex / k
            out[f"cut_{d}d"] = d * cut / k
        return out

    def peak_deviator(self, confinement: float, dim: int = 3) -> float:
        """The deviator q at failure in compression under the confining pressure
        ``confinement`` (compression positive): in 3D triaxial compression 3 alpha (p +
        p_a) / (sqrt(2/3) - alpha), equal to Mohr-Coulomb's (Klar's alpha is the outer
        cone); in the 2D law's biaxial compression 2 alpha (p + p_a) / (sqrt(1/2) - alpha)."""
        p = confinement + self.apex
        if dim == 3:
            return 3.0 * self.alpha * p / (math.sqrt(2.0 / 3.0) - self.alpha)
        return 2.0 * self.alpha * p / (math.sqrt(0.5) - self.alpha)

    def initial_state(self, stress, dim):
        # the 2D law's Hencky strain is the in-plane one (its trace over x and y)
        F, _ = self._hencky_state(stress, dim, plane_trace=True)
        return {"F": F}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        sig = ti.Matrix.zero(float, s.dim, s.dim)
        if ti.static(self.general):
            sig = self._update_general(s, p, F)
        elif ti.static(s.dim == 2):
            sig = self._update_2d(s, p, F)
        else:
            sig = self._update_svd(s, p, F)
        return sig

    @ti.func
    def _return_general(self, eps):
        """The principal elastic log strains (d of them) after the return to the cone
        with cohesion, dilatancy and the cut-off (see the class)."""
        d = ti.static(eps.n)
        cone = self.c.cone_2d() if ti.static(d == 2) else self.c.cone_3d()
        apex = self.c.apex_2d() if ti.static(d == 2) else self.c.apex_3d()
        cut = self.c.cut_2d() if ti.static(d == 2) else self.c.cut_3d()
        tr = eps.sum()
        dev = eps - tr / d
        dev_norm = dev.norm()
        out = eps
        if tr >= cut:  # past the cut-off: its apex, no deviator
            out = ti.Vector.zero(float, d) + cut / d
        else:
            f = dev_norm + cone * self.c.alpha() * (tr - apex)
            if f > 0.0:
                dg = f / (1.0 + self.c.alpha() * self.c.alpha_psi() * d * cone)
                if dg >= dev_norm:  # past the cone's apex: to it, on the cut-off
                    out = ti.Vector.zero(float, d) + ti.min(apex, cut) / d
                else:
                    out = eps - dg * dev / dev_norm - dg * self.c.alpha_psi()
                    tr_new = out.sum()
                    if tr_new > cut:  # the dilation crossed the cut-off: back onto it
                        out -= (tr_new - cut) / d
        return out

    @ti.func
    def _update_general(self, s: ti.template(), p, F):
        d = ti.static(s.dim)
        U, eps, V = self._principal_log_strains(s, F, d)
        eps_new = self._return_general(eps)
        change = eps - eps_new
        s.accumulate(s.plastic[p], (change - change.sum() / d).norm())
        return self._hencky_stress(s, p, U, V, eps_new, eps_new.sum())

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
            dgamma = dev_norm + self.c.cone_2d() * tr * self.c.alpha()
            if dgamma > 0.0:
                shift = dgamma / ti.sqrt(2.0)
                e1 -= shift
                e2 += shift
                g1 = ti.exp(-shift)
                g2 = 1.0 / g1
            else:
                dgamma = 0.0
        s.accumulate(s.plastic[p], dgamma)
        if dgamma > 0.0:  # plastic: the elastic part moves back onto the cone
            F = (0.5 * (g1 + g2) * eye + 0.5 * (g1 - g2) * A) @ F
        s.F[p] = F
        tr_e = e1 + e2
        tau1 = self.c.two_mu() * e1 + self.c.lam() * tr_e
        tau2 = self.c.two_mu() * e2 + self.c.lam() * tr_e
        T = 0.5 * (tau1 + tau2) * eye + 0.5 * (tau1 - tau2) * A
        return T * self._initial_over_current_volume(s, p)

    @ti.func
    def _update_svd(self, s: ti.template(), p, F):
        d = ti.static(s.dim)
        U, eps, V = self._principal_log_strains(s, F, d)
        # return mapping on the principal Hencky strains (Klar et al. 2016, Alg. 2)
        tr = eps.sum()
        dev = eps - tr / d
        dev_norm = dev.norm()
        dgamma = 0.0
        if tr >= 0.0:  # tension: cohesionless sand carries none, back to the cone tip
            dgamma = eps.norm()
            eps = ti.Vector.zero(float, d)
        else:
            cone = self.c.cone_2d() if ti.static(d == 2) else self.c.cone_3d()
            dgamma = dev_norm + cone * tr * self.c.alpha()
            if dgamma > 0.0:
                eps -= dgamma / dev_norm * dev
            else:
                dgamma = 0.0
        s.accumulate(s.plastic[p], dgamma)
        tau = ti.Vector.zero(float, d)
        tr_e = eps.sum()
        for k in ti.static(range(d)):
            tau[k] = self.c.two_mu() * eps[k] + self.c.lam() * tr_e
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
