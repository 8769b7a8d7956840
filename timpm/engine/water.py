"""The pore water of a scene's saturated particles (model/water.py): what it keeps per
particle, the buoyancy below a still-water level, and the split of the stress the grid
sees into the effective stress the laws act on and the excess pore pressure.

Pressures are excess pressures p_e over the hydrostatic p_h = rho_w |g| (level - y): the
hydrostatic part acts as the buoyant force rho_w V |g| on the particles below the level
(with the pressure of the water on the submerged faces it is Archimedes' buoyancy).  The
particle's ``sigma`` holds the stress the grid sees, sigma' - p_e I; the laws receive
sigma' = sigma + p_e I.
"""
import taichi as ti

from ..platform.declare import Field

__all__ = ["Pores"]


class Pores:
    """See the module: the feature set and the run-time values (the water level)."""

    def __init__(self, features, values):
        f = self.f = features
        self.dim = f.dim
        self.up = min(1, f.dim - 1)  # the up axis: y in 2D and 3D, x in 1D
        self.values = values

    @staticmethod
    def particle_fields(features) -> dict:
        """The per-particle state of the pore water (zero on a dry material's particles)."""
        fields = {"rho_w": Field(doc="the density of the water in the pores (0: dry)")}
        if features.pore_pressure:
            fields.update(
                pw=Field(doc="the excess pore pressure p_e (compression positive)"),
                storage=Field(doc="K_w / n: the pore pressure per unit volumetric compression"))
        if features.coupled:
            fields.update(
                porosity=Field(doc="the porosity n"),
                drag=Field(doc="Darcy's drag n rho_w g / k per unit volume"),
                w=Field("vector", doc="the pore water's velocity"))
        return fields

    @ti.func
    def buoyancy(self, particles: ti.template(), p):
        """-V_p grad p_h below the level (zero above it and on dry particles): -rho_w V_p g
        under still water; under a seepage parallel to x its y component only."""
        fb = ti.Vector.zero(float, self.dim)
        if ti.static(self.f.water_level):
            if particles.x[p][self.up] < self.values.water_level():
                g = self.values.gravity()
                if ti.static(self.f.phreatic):
                    # below the table y_w(x): -V grad p_h = rho_w V |g| (-y_w'(x), 1)
                    y_w, slope = self.table(particles.x[p][0])
                    if particles.x[p][1] < y_w:
                        fb[0] = particles.rho_w[p] * particles.vol[p] * g[1] * slope
                        fb[1] = -particles.rho_w[p] * particles.vol[p] * g[1]
                else:
                    if ti.static(self.f.seepage == "parallel"):
                        g[0] = 0.0
                    fb = -particles.rho_w[p] * particles.vol[p] * g
        return fb

    @ti.func
    def table(self, x):
        """The phreatic surface's height y_w and slope y_w' at x (constant beyond its
        ends): its vertices unrolled, the segment holding x found in order."""
        xs, ys = self.values.phreatic_x(), self.values.phreatic_y()
        y_w = ys[0]
        slope = 0.0
        for k in ti.static(range(self.f.phreatic - 1)):
            if x > xs[k]:
                if x <= xs[k + 1]:
                    slope = (ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k])
                    y_w = ys[k] + slope * (x - xs[k])
                else:
                    y_w = ys[k + 1]
                    slope = 0.0
        return y_w, slope

    @ti.func
    def effective(self, particles: ti.template(), p, sigma):
        """sigma' = sigma + p_e I: the effective stress of the stress the grid sees."""
        out = sigma
        if ti.static(self.f.pore_pressure):
            out = sigma + particles.pw[p] * ti.Matrix.identity(float, self.dim)
        return out

    @ti.func
    def seen(self, particles: ti.template(), p, sigma_eff, d_eps_v):
        """The stress the grid sees after the step: p_e -= (K_w / n) d_eps_v (the pores'
        volumetric strain this step: the skeleton's when undrained, the phases' mix when
        coupled), then sigma' - p_e I."""
        out = sigma_eff
        if ti.static(self.f.pore_pressure):
            pw = particles.pw[p] - particles.storage[p] * d_eps_v
            particles.pw[p] = pw
            out = sigma_eff - pw * ti.Matrix.identity(float, self.dim)
        return out
