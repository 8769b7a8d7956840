"""Compressible Neo-Hookean solid."""
import taichi as ti

from .base import SolidMaterial

__all__ = ["NeoHookean"]


class NeoHookean(SolidMaterial):
    """Compressible Neo-Hookean solid: sigma = (mu (F F^T - I) + lambda ln J I) / J, the
    stored energy W = mu / 2 (tr(F^T F) - d) - mu ln J + lambda / 2 (ln J)^2."""

    name = "neo-hookean"
    energy_function = True
    stress_from_F = True

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        F = self._trial_F(s, p, grad_du)
        s.F[p] = F
        return self.stress(s, p, F)

    @ti.func
    def stress(self, s: ti.template(), p, F):
        """sigma(F) = (mu (F F^T - I) + lambda ln J I) / J."""
        J = F.determinant()
        eye = ti.Matrix.identity(float, s.dim)
        return (self.c.mu() * (F @ F.transpose() - eye) + self.c.lam() * ti.log(J) * eye) / J

    @ti.func
    def energy(self, s: ti.template(), p):
        """W(F) V0 = (mu / 2 (tr(F^T F) - d) - mu ln J + lambda / 2 (ln J)^2) V0."""
        F = s.F[p]
        ln_J = ti.log(F.determinant())
        W = (0.5 * self.c.mu() * ((F.transpose() @ F).trace() - s.dim) - self.c.mu() * ln_J
             + 0.5 * self.c.lam() * ln_J * ln_J)
        return W * self.reference_volume(s, p)
