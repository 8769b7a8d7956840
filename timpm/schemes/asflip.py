"""ASFLIP: the affine transfer with a FLIP share of the velocity and position updates
(Fei, Guo, Wu, Huang and Gao 2021, "Revisiting integration in the material point method:
a scheme for easier separation and less dissipation", ACM Trans. Graph. 40(4), 109).

APIC (:mod:`.affine`) rebuilds a particle's velocity from the grid every step, v_p =
sum_i phi_i v_i^(n+1): whatever the grid cannot hold is lost, a numerical dissipation.
ASFLIP keeps a share alpha of the particle's own velocity beyond the grid's, as FLIP does,
and moves the particle by a share beta of it too where it separates from its neighbours:

    v_p^(n+1) = vpic + alpha (v_p^n - vold),
    x_p^(n+1) = x_p^n + dt (vpic + beta alpha (v_p^n - vold)),

vpic = sum_i phi_i v_i^(n+1) the grid's velocity after the forces and the walls, vold =
sum_i phi_i v_i^n the velocity P2G gave the grid before the forces (the affine part
included, no wall), and beta = beta_max where the particle expands (ln(V_p^(n+1) / V0_p) >=
-1e-3: it separates, and its own velocity may carry it out of the grid's averaged motion),
beta_min elsewhere (in compression the position follows the grid, which keeps particles
from interpenetrating).  alpha = 0 is APIC; C_p = B_p D_p^-1 is APIC's, the stress and the
external forces enter P2G as in APIC; the uniform B-splines only (D_p constant).
"""
import taichi as ti

from ..platform.declare import Field, Param
from .affine import Affine
from .phases import Nodes, Particles

__all__ = ["ASFLIP"]


class ASFLIP(Affine):
    """See the module."""

    transfers = ("asflip",)
    extended = True  # its own P2G at each stencil node and grid update at each node
    integrators = ("euler-cromer",)  # its G2P is its own: the midpoint iteration's is APIC's
    PARAMS = {
        "alpha": Param(0.95, "", "FLIP share of the velocity update (0: APIC, 1: FLIP)",
                       low=0.0, high=1.0),
        "beta_min": Param(0.0, "", "FLIP share of the position update in compression",
                          low=0.0, high=1.0),
        "beta_max": Param(1.0, "", "FLIP share of the position update where a particle "
                          "separates (expands)", low=0.0, high=1.0)}

    @classmethod
    def check(cls, transfer, dim, basis, mass, projection, damping, params):
        super().check(transfer, dim, basis, mass, projection, damping, params)
        if not basis.name.startswith("uniform-bspline"):
            raise ValueError(f"the asflip transfer takes the uniform B-splines (D_p "
                             f"constant): uniform-bsplineN, not {basis.name}")
        if params["beta_min"] > params["beta_max"]:
            raise ValueError(f"the asflip transfer: beta_min = {params['beta_min']:g} must not "
                             f"exceed beta_max = {params['beta_max']:g}")

    @staticmethod
    def grid_fields(features):
        return {**Affine.grid_fields(features),
                "gq0": Field("vector", scatter=True, names=("node_old_momentum",),
                             doc="P0_i = sum m_p phi_i (v_p + C_p (x_i - x_p)), P2G's momentum "
                                 "before the forces"),
                "gv0": Field("vector", names=("node_old_velocity",),
                             doc="v_i^n = P0_i / m_i: the FLIP share's base")}

    def phases(self):
        return (self.p2g,
                Nodes("grid: v_i = P_i / m_i, walls; v_i^n = P0_i / m_i", self.velocity_node),
                Particles("G2P: v_p = vpic + alpha (v_p - vold), C_p, grad v, sigma_p, V_p; "
                          "x_p += dt (vpic + beta alpha (v_p - vold))", self.update_particle))

    @ti.func
    def p2g_node(self, values: ti.template(), copy, node, phi, momentum, fp):
        # P0_i: APIC's momentum at the node without the forces' impulse dt phi_i f_p
        self.scatter.add("node_old_momentum", copy, node, momentum - phi * values.dt() * fp)

    @ti.func
    def after_velocity(self, grid: ti.template(), values: ti.template(), I, m):
        # v_i^n = P0_i / m_i (no wall: the FLIP share carries the grid's whole change);
        # P0_i cleared for the next P2G
        P0 = self.scatter.merged("node_old_momentum", I)
        v0 = ti.Vector.zero(float, self.dim)
        if m > values.mass_tol():
            v0 = P0 / m
        grid.node_old_velocity[I] = v0
        if ti.static(not self.f.private_scatter):
            grid.node_old_momentum[I] = ti.Vector.zero(float, self.dim)

    @ti.func
    def update_particle(self, particles: ti.template(), grid: ti.template(),
                        values: ti.template(), p):
        # G2P: vpic, C_p and grad du as APIC's; vold; the FLIP shares of the velocity and
        # (separating: V_p^(n+1) / V0 >= exp(-1e-3)) of the position
        base, w, dw, xi, inside = self.stencil.of(particles.x[p])
        if inside and not self.failures.halted(p):
            v_n = particles.v[p]
            vpic, grad_du = self.gather(particles, grid, values, p, base, w, dw, xi)
            vold = self.stencil.interpolate(grid.node_old_velocity, base, w, dw)
            flip = values.alpha() * (v_n - vold)
            expansion = (particles.vol[p] * self.g2p.jacobian(grad_du)
                         / self.laws.reference_volume(p))
            beta = values.beta_min()
            if expansion >= ti.exp(-1e-3):
                beta = values.beta_max()
            vp = vpic + flip
            particles.v[p] = vp
            self.g2p.update(particles, values, p, vp, (vpic + beta * flip) * values.dt(),
                            grad_du)
