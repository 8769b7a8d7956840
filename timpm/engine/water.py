"""The pore water of a scene's saturated particles (model/water.py): what it keeps per
particle, the buoyancy below a still-water level, and the split of the stress the grid
sees into the effective stress the laws act on and the excess pore pressure.

Pressures are excess pressures p_e over the hydrostatic p_h = rho_w |g| (level - y): the
hydrostatic part acts as the buoyant force rho_w V |g| on the particles below the level
(with the pressure of the water on the submerged faces it is Archimedes' buoyancy).  The
particle's ``sigma`` holds the stress the grid sees, sigma' - p_e I; the laws receive
sigma' = sigma + p_e I.

With ``Water(smoothing="cell")`` the pressure waits for the cell: G2P adds each particle's
pore strain, times its volume, to its grid cell, and a particle phase after it applies the
cell's mean, dp_e = -(K_w / n) sum_c V_q d eps_q / sum_c V_q, then a node phase clears the
sums (:meth:`Pores.phases`).
"""
import taichi as ti

from ..platform.declare import Field
from ..schemes.phases import Nodes, Particles

__all__ = ["Pores"]


class Pores:
    """See the module: the feature set and the run-time values (the water level)."""

    def __init__(self, features, values, grid=None, accumulate=None, run=None):
        f = self.f = features
        self.dim = f.dim
        self.up = min(1, f.dim - 1)  # the up axis: y in 2D and 3D, x in 1D
        self.values = values
        self.grid, self.accumulate = grid, accumulate  # (the cell sums: smoothing)
        self.run = run  # (the time: a drawdown's level)

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
        if features.drawdown and features.pore_pressure:
            fields["ground"] = Field(doc="the ground surface y_s above the particle (a "
                                         "drawdown's unloading of the pore water)")
        if features.pore_smoothing:
            fields["pore_pending"] = Field(dtype="int", scratch=True,
                                           doc="1: the particle's pore strain is in its "
                                               "cell's sums, its p_e waiting for the mean")
            if features.path_work:
                fields["pore_dilation"] = Field(scratch=True, doc="the step's tr(d eps) (the "
                                                                 "pressure increment's work)")
        return fields

    @staticmethod
    def grid_fields(features) -> dict:
        """The cell sums of the smoothing, at each cell's lowest node."""
        if not features.pore_smoothing:
            return {}
        return {"gcv": Field(names=("cell_volume",), doc="sum_c V_p over a cell's particles"),
                "gcd": Field(names=("cell_dilation",),
                             doc="sum_c V_p d eps_p: the cell's pore strain, times volume")}

    def phases(self) -> tuple:
        """The phases after G2P: the cell's mean pore strain applied, the sums cleared."""
        if not self.f.pore_smoothing:
            return ()
        return (Particles("pore pressure: p_e -= (K_w / n) sum_c V d eps / sum_c V (the "
                          "cell's mean)", self.smoothed_particle),
                Nodes("clear the cell sums", self.clear_cell))

    @ti.func
    def buoyancy(self, particles: ti.template(), p):
        """-V_p grad p_h below the level (zero above it and on dry particles): -rho_w V_p g
        under still water; under a seepage parallel to x its y component only."""
        fb = ti.Vector.zero(float, self.dim)
        if ti.static(self.f.drawdown):  # (still water: no phreatic surface, no seepage)
            fb = -self.submerged(particles, p) * particles.rho_w[p] * particles.vol[p] \
                * self.values.gravity()
        elif ti.static(self.f.water_level):
            if particles.x[p][self.up] < self.level():
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
    def submerged(self, particles: ti.template(), p):
        """The share of the particle below the level: 1 or 0 by its centre; under a
        drawdown, whose level passes through the particles, the share of its extent
        V^(1/d) below the level (its buoyancy then fades as the level passes, not at once)."""
        share = 0.0
        if ti.static(self.f.drawdown):
            extent = particles.vol[p] ** (1.0 / self.dim)
            share = ti.min(ti.max((self.level() - particles.x[p][self.up]) / extent + 0.5,
                                  0.0), 1.0)
        elif particles.x[p][self.up] < self.level():
            share = 1.0
        return share

    @ti.func
    def level(self):
        """The still-water level now (a drawdown's at the step's time)."""
        L = self.values.water_level()
        if ti.static(self.f.drawdown):
            L = self.level_at(self.run.time[None])
        return L

    @ti.func
    def level_at(self, t):
        """The still-water level at time t: a drawdown's linear from level to final_level
        over drawdown_time, then held."""
        L = self.values.water_level()
        if ti.static(self.f.drawdown):
            share = ti.min(ti.cast(t, float) / self.values.drawdown_time(), 1.0)
            L += (self.values.final_level() - L) * share
        return L

    @ti.func
    def drawdown_shift(self, particles: ti.template(), p):
        """The step's dp_e of a drawdown, B = 1: the total pore pressure stays where the
        level passes between the particle and its ground surface y_s, dp_e = -rho_w |g| dL
        over the part of the level's move within (y, y_s)."""
        t = self.run.time[None]
        before, after = self.level_at(t), self.level_at(t + self.values.dt())
        y = particles.x[p][self.up]
        lo = ti.max(ti.min(before, after), y)
        hi = ti.min(ti.max(before, after), particles.ground[p])
        gamma_w = -particles.rho_w[p] * self.values.gravity()[self.up]
        return ti.math.sign(before - after) * gamma_w * ti.max(hi - lo, 0.0)

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
        coupled), then sigma' - p_e I.  Smoothed, p_e is the step's old one until the
        cell's mean comes (:meth:`smoothed_particle`)."""
        out = sigma_eff
        if ti.static(self.f.pore_pressure):
            pw = particles.pw[p]
            if ti.static(not self.f.pore_smoothing):
                pw -= particles.storage[p] * d_eps_v
            if ti.static(self.f.drawdown):  # the free water's unloading (B = 1)
                pw += self.drawdown_shift(particles, p)
            if ti.static(not self.f.pore_smoothing or self.f.drawdown):
                particles.pw[p] = pw
            out = sigma_eff - pw * ti.Matrix.identity(float, self.dim)
        return out

    @ti.func
    def water_weight(self, particles: ti.template(), p):
        """The weight rho_w V g of the pore water above the level (coupled: below it the
        hydrostatic pressure's gradient carries it, p_e being the excess); zero below."""
        out = ti.Vector.zero(float, self.dim)
        if ti.static(self.f.water_level):
            out = ((1.0 - self.submerged(particles, p)) * particles.rho_w[p]
                   * particles.vol[p] * self.values.gravity())
        return out

    # ---- smoothing: the cell's mean pore strain --------------------------------------------
    @ti.func
    def cell_of(self, x):
        """The grid cell holding x (its lowest node's index), clamped to the grid."""
        c = ti.Vector.zero(ti.i32, self.dim)
        for k in ti.static(range(self.dim)):
            c[k] = ti.min(ti.max(ti.cast(ti.floor((x[k] - self.values.origin()[k])
                                                  * self.values.inv_h()), ti.i32), 0),
                          self.values.elements()[k] - 1)
        return c

    @ti.func
    def deposit(self, particles: ti.template(), p, x, vol, d_eps_v, dilation):
        """G2P, smoothed: the particle's pore strain V d eps into the sums of its cell (at
        its new position x), kept for the phase after."""
        if ti.static(self.f.pore_smoothing):
            c = self.cell_of(x)
            self.accumulate(self.grid.cell_volume[c], vol)
            self.accumulate(self.grid.cell_dilation[c], vol * d_eps_v)
            particles.pore_pending[p] = 1
            if ti.static(self.f.path_work):
                particles.pore_dilation[p] = dilation

    @ti.func
    def smoothed_particle(self, particles: ti.template(), grid: ti.template(),
                          values: ti.template(), p):
        # the pore pressure from the cell's mean strain: <d eps> = sum_c V d eps / sum_c V,
        # dp_e = -(K_w / n) <d eps>, sigma -= dp_e I (the work: -dp_e V tr(d eps) / 2)
        if particles.pore_pending[p] != 0:
            c = self.cell_of(particles.x[p])
            mean = grid.cell_dilation[c] / grid.cell_volume[c]
            dp = -particles.storage[p] * mean
            particles.pw[p] += dp
            particles.sigma[p] -= dp * ti.Matrix.identity(float, self.dim)
            if ti.static(self.f.path_work):
                particles.work[p] -= 0.5 * dp * particles.vol[p] * particles.pore_dilation[p]
            particles.pore_pending[p] = 0

    @ti.func
    def clear_cell(self, grid: ti.template(), values: ti.template(), I):
        # the cell sums back to zero for the next step
        grid.cell_volume[I] = 0.0
        grid.cell_dilation[I] = 0.0
