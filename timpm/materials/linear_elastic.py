"""Small-strain linear elasticity."""
import taichi as ti

from .base import SolidMaterial

__all__ = ["LinearElastic"]


class LinearElastic(SolidMaterial):
    """Small-strain linear elasticity: sigma = lambda tr(eps) I + 2 mu eps, eps = sym(F) - I."""

    name = "linear-elastic"

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        s.F[p] = F
        eps = 0.5 * (F + F.transpose()) - ti.Matrix.identity(float, s.dim)
        return (self.c.lam() * eps.trace() * ti.Matrix.identity(float, s.dim)
                + self.c.two_mu() * eps)
