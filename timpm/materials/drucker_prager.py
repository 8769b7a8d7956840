"""Cohesionless Drucker-Prager sand."""
import math

import taichi as ti

from .base import SolidMaterial

__all__ = ["DruckerPrager"]


class DruckerPrager(SolidMaterial):
    """Cohesionless Drucker-Prager sand (Klar et al. 2016): Hencky elasticity with a
    return mapping of the principal logarithmic strains onto the cone, tension cut off.

    ``F`` holds the elastic deformation gradient, ``plastic`` the accumulated plastic
    strain |d gamma| (for colouring and post-processing).
    """

    name = "drucker-prager"
    needs = frozenset({"F", "plastic"})
    free_expansion = True  # no tension: a particle expands stress-free
    CONSTANTS = SolidMaterial.CONSTANTS + ("alpha", "cone_2d", "cone_3d")
    dims = (2, 3)  # the return mapping of principal strains: 2D spectral form, 3D SVD

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

    def constants(self, dt: float) -> dict:
        # (d lambda + 2 mu) / (2 mu): the trace's share of the return to the cone in d dims
        return {**super().constants(dt), "alpha": self.alpha,
                "cone_2d": (2.0 * self.lam + 2.0 * self.mu) / (2.0 * self.mu),
                "cone_3d": (3 * self.lam + 2.0 * self.mu) / (2.0 * self.mu)}

    def elastic_state(self, stress, dim):
        # the 2D law's Hencky strain is the in-plane one (its trace over x and y)
        return self._hencky_state(stress, dim, plane_trace=True)

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
