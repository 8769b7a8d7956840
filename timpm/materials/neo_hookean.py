"""Compressible Neo-Hookean solid."""
import taichi as ti

from .base import SolidMaterial

__all__ = ["NeoHookean"]


class NeoHookean(SolidMaterial):
    """Compressible Neo-Hookean solid: sigma = (mu (F F^T - I) + lambda ln J I) / J."""

    name = "neo-hookean"

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        s.F[p] = F
        J = F.determinant()
        eye = ti.Matrix.identity(float, s.dim)
        return (self.c.mu() * (F @ F.transpose() - eye) + self.c.lam() * ti.log(J) * eye) / J
