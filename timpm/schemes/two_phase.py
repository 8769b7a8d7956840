"""The single-point two-phase MUSL step: a saturated soil whose pore water flows
(``Water(analysis="coupled")``, model/water.py), in the formulation of Anura3D (Al-Kafaji
2013; one material point carries the skeleton and its pore water):

- the water, per unit volume, rho_w a_w = -grad p_e - (n rho_w g / k)(w - v) (Darcy's
  drag against the skeleton's velocity v; the hydrostatic pressure's gradient balances the
  water's weight: p_e is the excess over it);
- the mixture, (1 - n) rho_s a_s + n rho_w a_w = div(sigma' - p_e I) + rho' g (the weight
  buoyant below a still-water level);
- the pores, dp_e = -(K_w / n) [(1 - n) d eps_v,s + n d eps_v,w].

At the nodes, with M_i = sum phi_i m_p (the mixture), Mbar_i = sum phi_i n rho_w V0_p
(its water), M_w,i = sum phi_i rho_w V_p, Q_i = sum phi_i (n rho_w g / k) V_p and the
forces F_i (MUSL's, from sigma' - p_e I) and F_w,i = sum p_e V_p grad phi_i, the two
balances are solved for the velocities at the step's end with the drag taken there
(implicitly):

    (M_w / dt + Q) w+ - Q v+ = F_w + M_w w / dt,
    Mbar w+ / dt + (M - Mbar) v+ / dt = F + (M - Mbar) v / dt + Mbar w / dt,

so that a low permeability (Q large) does not shorten the time step: the step is bounded
by the undrained wave, sqrt((E_oed + K_w / n) / rho_sat), not by the drag's 2 M_w / Q.
A node's water is held by its walls (impermeable: the normal velocity the skeleton's) and
by its Dirichlet conditions, except on the sides the scene drains (``Water.drained_sides``)
and at its drained plane walls (``Plane.drained``), where the water's own balance is solved
with the skeleton's velocity held, w+ = (F_w + M_w w / dt + Q v+) / (M_w / dt + Q).  (The
box's walls apply their own projection to the water; an impermeable plane wall makes the
water's normal velocity the skeleton's, w -= (w . n - v+ . n) n, its tangential part free:
model/walls.py.)  A free surface drains (p_e = 0 is the weak form's
natural condition, there and on a drained side).  A drained side's prescribed excess pore
pressure p_b (``Water.side_pressure``) is the weak form's traction -p_b n there: its nodal
force -p_b n int phi_i dA (model/water.py, ``side_pressure_forces``), times f(t), is added
to F_w and to the mixture's F (the total traction's share) before the solve.  The
skeleton's is MUSL's step: the particles' velocities updated, their momentum mapped again,
the strain from that velocity.  The water's volumetric strain is taken from its velocity
at the step's end, w+, itself: remapped from the particles, the nodal field is a smoothed
one, and consolidation ran slower than Terzaghi's series by a share growing as 1 / (rho_w
h) (4% of the time factor at 64 elements; with w+, 0.0004 of u0 at 16 to 64 elements,
docs/results.md).  On the linear basis the water of a node the body barely fills is
floored (``WATER_FILL_FLOOR``): its grad phi stays 1 / h where phi and with it M_w and Q
vanish.
"""
import taichi as ti

from ..platform.declare import Field
from .musl import MUSL
from .phases import Nodes, Particles, Scatter, Whole

__all__ = ["TwoPhase", "WATER_FILL_FLOOR"]

#: on a kinked basis (linear: Basis.kinked) the water at a node the body fills to less
#: than this share of a full node's water, rho_w h^dim, takes its force F_w scaled by
#: M_w / that floor (as if its water and drag were the floor's).  F_w grows with grad phi
#: where M_w and Q shrink with phi, so the water at a node the body barely reaches (a
#: free top just above a node row: fill ~ t^2 / 2 for a layer t h thick) drained without
#: bound and the step blew up, at fills of 0.005 and less (Terzaghi's column, ppc 10 and
#: 20, the default step).  0.02 keeps the largest gain, about t / max(t^2 / 2, floor)
#: (at most 10), below that of the fill 0.011 (t = 0.15: 13), measured stable; rows below
#: the thin top layer then follow the series within 0.008 of u0 at T = 0.05 and 0.0031 at
#: T = 0.2 (aligned: 0.0033, 0.0011; tests/test_water.py), and the goldens keep their bits
WATER_FILL_FLOOR = 0.02


class TwoPhase(MUSL):
    """See the module."""

    transfers = ("musl",)
    # (MUSL's integrators, as the PIC blend keeps them: the Model refuses pore water with
    # any but Euler-Cromer, model/model.py, before a scheme is chosen)

    @classmethod
    def applies(cls, features) -> bool:
        return features.transfer == "musl" and features.coupled

    @staticmethod
    def grid_fields(features):
        pressured = {} if not features.has_side_pressure else {
            "gwb": Field("vector", names=("node_side_force",),
                         doc="-sum_s p_s n_s int_s phi_i dA: the drained sides' prescribed "
                             "pore pressures (Water.side_pressure), times f(t)")}
        return {**MUSL.grid_fields(features), **pressured,
                "gwm": Field(scatter=True, names=("node_water_mass",),
                             doc="M_w,i = sum phi_i rho_w V_p"),
                "gwn": Field(scatter=True, names=("node_pore_mass",),
                             doc="Mbar_i = sum phi_i n rho_w V0_p: the water's share of m_i"),
                "gwq": Field(scatter=True, names=("node_drag",),
                             doc="Q_i = sum phi_i (n rho_w g / k) V_p"),
                "gwf": Field("vector", scatter=True, names=("node_water_force",),
                             doc="F_w,i = sum p_e V_p grad phi_i"),
                "gwp": Field("vector", scatter=True, names=("node_water_momentum",),
                             doc="P_w,i = sum phi_i rho_w V_p w_p"),
                "gwa": Field("vector", names=("node_water_acceleration",),
                             doc="a_w,i = (w_i+ - w_i) / dt"),
                "gwe": Field("vector", names=("node_water_velocity",),
                             doc="w_i+: the water's velocity at the step's end")}

    extended = True        # the water's P2G at each stencil node (p2g_node)
    needs_momentum = True  # the drag's solve reads v_i = P_i / m_i

    def __init__(self, features, ops):
        super().__init__(features, ops)
        self.p2g = Scatter("P2G: m_i, F_i, P_i; M_w,i, Mbar_i, Q_i, F_w,i, P_w,i",
                           self.p2g_particle,
                           rows=("node_mass", "node_force", "node_momentum"),
                           merge=("node_mass", "node_momentum", "node_force"))
        self.velocity = Scatter("G2P: v_p += dt sum phi_i a_i, w_p += dt sum phi_i a_w,i; "
                                "P2G: P_i", self.velocity_particle,
                                rows=("node_momentum",), merge=("node_momentum",))

    def phases(self):
        steps = []
        if not self.f.private_scatter:
            steps.append(Whole("clear the grid", self.clear))
        return tuple(steps) + (
            self.p2g,
            Nodes("grid: both phases' velocities at the step's end, Darcy's drag implicit; "
                  "walls", self.acceleration_node),
            self.velocity,
            Nodes("grid: v_i = P_i / m_i, walls", self.velocity_node),
            Particles("G2P: u_p, grad du, sigma', p_e -= (K_w / n) [(1 - n) d eps_s + n "
                      "d eps_w], V_p", self.update_particle))

    # ---- P2G ---------------------------------------------------------------------------
    @ti.func
    def p2g_node(self, particles: ti.template(), values: ti.template(), p, copy, node, phi,
                 grad):
        # P2G of the water beside MUSL's m_i, P_i and F_i (whose stress is sigma' - p_e I):
        # M_w,i, Mbar_i, Q_i, F_w,i = sum (p_e V_p grad phi_i + phi_i rho_w V_p g [above
        # the level]), P_w,i
        vol = particles.vol[p]
        water_mass = particles.rho_w[p] * vol
        self.scatter.add("node_water_mass", copy, node, phi * water_mass)
        self.scatter.add("node_pore_mass", copy, node, phi * particles.porosity[p]
                         * particles.rho_w[p] * self.laws.reference_volume(p))
        self.scatter.add("node_drag", copy, node, phi * particles.drag[p] * vol)
        self.scatter.add("node_water_force", copy, node, particles.pw[p] * vol * grad
                         + phi * self.loads.pores.water_weight(particles, p))
        self.scatter.add("node_water_momentum", copy, node, phi * water_mass * particles.w[p])

    # ---- the grid: the coupled balances ------------------------------------------------
    @ti.func
    def acceleration_node(self, grid: ti.template(), values: ti.template(), I):
        # (M_w / dt + Q) w+ - Q v+ = F_w + M_w w / dt and Mbar w+ / dt + M_s v+ / dt = F +
        # M_s v / dt + Mbar w / dt (M_s = m_i - Mbar_i), solved node by node; walls on both
        # (impermeable); a_i = (v+ - v) / dt, a_w,i = (w+ - w) / dt; zero at Dirichlet and
        # empty nodes
        Mw = self.scatter.merged("node_water_mass", I)
        Mbar = self.scatter.merged("node_pore_mass", I)
        Q = self.scatter.merged("node_drag", I)
        Fw = self.scatter.merged("node_water_force", I)
        Pw = self.scatter.merged("node_water_momentum", I)
        dt = values.dt()
        if ti.static(self.f.water_floor):  # the water's force at a barely filled node
            if Mw < values.water_mass_floor():
                Fw *= Mw / values.water_mass_floor()
        if ti.static(self.f.has_side_pressure):
            # the drained sides' pressures p_b: the traction -p_b n f(t) on the water, and
            # on the mixture (its total traction; the held skeleton's reaction the rest)
            if Mw > values.mass_tol():
                Fb = grid.node_side_force[I] * self.f.side_pressure.at(
                    self.boundary.run.time[None], values.side_pressure_param())
                Fw += Fb
                grid.node_force[I] += Fb
        if ti.static(self.f.damping):  # F_damp = -alpha sgn(v_i) |F_i| (A.4), on the mixture
            grid.node_force[I] -= (values.damping() * ti.math.sign(grid.node_momentum[I])
                                   * ti.abs(grid.node_force[I]))
        a = ti.Vector.zero(float, self.dim)
        aw = ti.Vector.zero(float, self.dim)
        w_end = ti.Vector.zero(float, self.dim)  # (zero at Dirichlet and empty nodes)
        m = grid.node_mass[I]
        wet = Mw > values.mass_tol()
        A = Mw / dt
        w = ti.Vector.zero(float, self.dim)
        if wet:
            w = Pw / Mw
        R1 = Fw + A * w
        drains = self.drains(values, I)
        if m > values.mass_tol() and not self.boundary.is_fixed(I):
            v = grid.node_momentum[I] / m
            if not wet:
                w = v
            v_new = v + dt * grid.node_force[I] / m
            w_new = v_new
            if wet:
                B = (m - Mbar) / dt
                C = Mbar / dt
                R2 = grid.node_force[I] + B * v + C * w
                w_new = (B * R1 + Q * R2) / (B * (A + Q) + Q * C)
                v_new = (R2 - C * w_new) / B
            if ti.static(self.f.walled):
                # the skeleton held by the box's walls and the planes (model/walls.py)
                v_new = self.boundary.apply_walls(I, v_new)
                if drains and wet:  # the water through the wall: its balance, v+ held,
                    w_new = (R1 + Q * v_new) / (A + Q)  # then the other sides' walls
                    w_new = self.boundary.walls_except(I, w_new, self.f.drained_sides)
                else:  # impermeable: the box's walls project the water as the skeleton
                    w_new = self.boundary.walls_except(I, w_new, ())
                if ti.static(self.f.has_planes):  # impermeable planes: w_n made v+'s
                    w_new = self.boundary.water_at_planes(I, w_new, v_new)
            a = (v_new - v) / dt
            aw = (w_new - w) / dt
            w_end = w_new
        elif m > values.mass_tol() and drains and wet:
            # a Dirichlet node of a drained side: the skeleton held (v+ = 0, the coupled
            # analysis takes no prescribed motion), the water through it
            w_end = R1 / (A + Q)
            if ti.static(self.f.has_walls):
                w_end = self.boundary.walls_except(I, w_end, self.f.drained_sides)
            if ti.static(self.f.has_planes):
                w_end = self.boundary.water_at_planes(I, w_end,
                                                      ti.Vector.zero(float, self.dim))
            aw = (w_end - w) / dt
        grid.node_acceleration[I] = a
        grid.node_water_acceleration[I] = aw
        grid.node_water_velocity[I] = w_end
        grid.node_momentum[I] = ti.Vector.zero(float, self.dim)  # the second P2G's
        if ti.static(not self.f.private_scatter):  # (merged cleared the copies)
            grid.node_water_mass[I] = 0.0
            grid.node_pore_mass[I] = 0.0
            grid.node_drag[I] = 0.0
            grid.node_water_force[I] = ti.Vector.zero(float, self.dim)
            grid.node_water_momentum[I] = ti.Vector.zero(float, self.dim)

    @ti.func
    def drains(self, values: ti.template(), I):
        """Node I lies on a side the pore water flows through (Water.drained_sides: at and
        beyond its edge node, as a wall acts) or is held by a drained plane
        (Plane.drained)."""
        out = False
        if ti.static(self.f.has_drained_planes):
            out = self.boundary.on_drained_plane(I)
        for j in ti.static(range(len(self.f.drained_sides))):
            side = ti.static(self.f.drained_sides[j])
            edge = values.drained_nodes()[j]
            if ti.static(side % 2 == 0):
                if I[side // 2] <= edge:
                    out = True
            else:
                if I[side // 2] >= edge:
                    out = True
        return out

    # ---- G2P of the velocities, P2G of the momenta ----------------------------------------
    @ti.func
    def velocity_particle(self, particles: ti.template(), grid: ti.template(),
                          values: ti.template(), p, copy):
        # G2P: v_p += dt sum_i phi_i a_i, w_p += dt sum_i phi_i a_w,i; P2G: P_i = sum m_p
        # phi_i v_p
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        node_values = ti.Matrix.zero(float, 3, self.support)
        if inside:
            vp = particles.v[p] + values.dt() * self.stencil.interpolate(
                grid.node_acceleration, base, w, dw)
            wp = particles.w[p] + values.dt() * self.stencil.interpolate(
                grid.node_water_acceleration, base, w, dw)
            particles.v[p] = vp
            particles.w[p] = wp
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    node_values = self.scatter.deposit("node_momentum", copy, self.stencil.node(base, offset),
                                                       offset, particles.m[p] * phi * vp,
                                                       node_values)
        return base, inside, node_values

    # ---- G2P of the particle state ---------------------------------------------------------
    @ti.func
    def update_particle(self, particles: ti.template(), grid: ti.template(),
                        values: ti.template(), p):
        # G2P: v_p and grad du from v_i (MUSL's gather); the water's d eps_v,w = sum_i dt
        # w_i+ . grad phi_i; the pores' (1 - n) d eps_v,s + n d eps_v,w
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside and not self.failures.halted(p):
            vp, grad_du = self.gather(particles, grid, values, p, base, w, dw, xi)
            d_eps_w = 0.0
            for r in range(self.stencil.rows):
                for a, offset, phi, grad in ti.static(self.stencil.row(w, dw, r)):
                    d_eps_w += values.dt() * grid.node_water_velocity[self.stencil.node(base, offset)].dot(grad)
            n = particles.porosity[p]
            self.g2p.update_with_pores(particles, values, p, vp, vp * values.dt(), grad_du,
                                       (1.0 - n) * grad_du.trace() + n * d_eps_w)
