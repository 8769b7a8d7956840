"""The study's 1D law."""

import taichi as ti

from ..platform.declare import Field, Param
from .base import Material

__all__ = ["Hypoelastic1D"]


class Hypoelastic1D(Material):
    """The study's 1D law (2.2.4): d_sigma = (E - sigma) d_eps (``study``), or E d_eps.

    By default the study's forward-Euler update with d_eps = g, the step's
    displacement-increment gradient: sigma += (E - sigma) g, or sigma += E g.  With
    ``exact`` the same rate law is integrated exactly over a step of constant g
    (d_eps = dF / F, F_new = (1 + g) F_old): E - sigma_new = (E - sigma_old) / (1 + g), so
    sigma = E (1 - 1 / F); or sigma_new = sigma_old + E ln(1 + g), so sigma = E ln F.
    The forward-Euler form differs from it by O(g^2) of one sign every step: over long
    runs a mean stress builds up that the grid does not see (docs/results.md, stability
    audit).  Exactly integrated, both laws are hyperelastic in 1D and the records report
    the stored energy W(F) V0 with F = V / V0; the forward-Euler records the path work.

    A :class:`timpm.model.scene.Scene` makes it from its :class:`timpm.model.scene.Material`; a 1D
    :class:`timpm.model.world.World` takes it as a body's material.  The density acts through
    the particle masses."""

    name = "hypoelastic-1d"
    CONSTANTS = ("E", "density")
    dims = (1,)
    carries_pore_water = True

    PARAMS = {**Material.PARAMS,
              "E": Param(unit="Pa", doc="Young's modulus", low=0.0, low_open=True),
              "study": Param(kind="bool", doc="the study's stress update"),
              "exact": Param(kind="bool", doc="integrated exactly over a step")}

    def __init__(self, E, density, study: bool = True, exact: bool = False):
        super().__init__(density)
        self.E, self.study = self.checked("E", E), self.checked("study", study)
        self.exact = self.checked("exact", exact)
        self.stress_from_F = self.exact  # exactly integrated: sigma(F), F = V / V0
        self.wave_speed = self.speed_of("E", self.E)

    @classmethod
    def particle_fields(cls, dim):
        return {"eps": Field("matrix", doc="the accumulated (logarithmic) strain")}

    def parameters(self) -> dict:
        return {"E": self.E, "density": self.density, "study": self.study, "exact": self.exact}

    def flags(self) -> tuple:
        return (self.study, self.exact)

    def set_flags(self, flags):
        self.study, self.exact = flags

    @classmethod
    def has_energy_function(cls, flags: tuple) -> bool:
        return bool(flags[1])  # exactly integrated: sigma is a function of F

    def constants(self, dt: float, h: float) -> dict:
        return {"E": self.E, "density": self.density}

    @ti.func
    def update(self, s: ti.template(), p, grad_du, sigma_old):
        sig_new = sigma_old
        if ti.static(self.exact):
            # d_eps = ln(1 + g) = ln(F_new / F_old) (a non-positive 1 + g gives NaN here;
            # the engine stops the run on the particle's non-positive volume)
            stretch = 1.0 + grad_du[0, 0]
            log_strain = ti.log(stretch)
            sig_new = sigma_old + self.c.E() * log_strain
            if ti.static(self.study):
                sig_new = self.c.E() - (self.c.E() - sigma_old) / stretch
            s.accumulate(s.eps[p], log_strain * ti.Matrix.identity(float, 1))
        else:
            deps = 0.5 * (grad_du + grad_du.transpose())
            sig_new = sigma_old + self.c.E() * deps
            if ti.static(self.study):
                sig_new = sigma_old + (self.c.E() - sigma_old) * deps
            s.accumulate(s.eps[p], deps)
        return sig_new

    @ti.func
    def stress(self, s: ti.template(), p, F):
        """The exactly integrated laws (``exact``) at F: sigma = E (1 - 1 / F) or E ln F;
        the accumulated strain eps = ln F."""
        stretch = F[0, 0]
        s.eps[p] = ti.log(stretch) * ti.Matrix.identity(float, 1)
        sig = self.c.E() * ti.log(stretch)
        if ti.static(self.study):
            sig = self.c.E() * (1.0 - 1.0 / stretch)
        return sig * ti.Matrix.identity(float, 1)

    @ti.func
    def energy(self, s: ti.template(), p):
        """W(F) V0 with F = V / V0 (``exact`` only): E (F - 1 - ln F) for
        sigma = E (1 - 1 / F), E (F ln F - F + 1) for sigma = E ln F; dW/dF = sigma."""
        V0 = self.reference_volume(s, p)
        F = s.vol[p] / V0
        W = self.c.E() * (F * ti.log(F) - F + 1.0)
        if ti.static(self.study):
            W = self.c.E() * (F - 1.0 - ti.log(F))
        return W * V0
