"""Small-strain linear elasticity."""
import taichi as ti

from .base import SolidMaterial

__all__ = ["LinearElastic"]


class LinearElastic(SolidMaterial):
    """Small-strain linear elasticity: sigma = lambda tr(eps) I + 2 mu eps, eps = sym(F) - I."""

    name = "linear-elastic"
    energy_function = True
    stress_from_F = True

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        s.F[p] = F
        return self.stress(s, p, F)

    @ti.func
    def stress(self, s: ti.template(), p, F):
        """sigma(F) = lambda tr(eps) I + 2 mu eps, eps = sym(F) - I."""
        eps = 0.5 * (F + F.transpose()) - ti.Matrix.identity(float, s.dim)
        return (self.c.lam() * eps.trace() * ti.Matrix.identity(float, s.dim)
                + self.c.two_mu() * eps)

    @ti.func
    def energy(self, s: ti.template(), p):
        """W(eps) V0 = (mu eps : eps + lambda / 2 tr(eps)^2) V0."""
        F = s.F[p]
        eps = 0.5 * (F + F.transpose()) - ti.Matrix.identity(float, s.dim)
        trace = eps.trace()
        W = 0.5 * self.c.two_mu() * (eps * eps).sum() + 0.5 * self.c.lam() * trace * trace
        return W * self.reference_volume(s, p)
