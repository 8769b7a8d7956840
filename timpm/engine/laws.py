"""The scene's constitutive laws as one unit: the per-material dispatch, written once.

Each material of a scene is compiled as its own unit (``Material.unit``); a scene of one
material calls it directly, a scene that mixes them branches on the particle's material
index (``mat[p]``), each branch compiled in (:meth:`Laws.call`).  The laws receive the
particle state (:class:`~timpm.engine.views.MaterialState`), never the program.
"""
import taichi as ti

__all__ = ["Laws"]


class Laws:
    """The compiled ``units`` of the scene's materials, in material-index order; the
    particle state they read and write (``state``, with the material index ``mat`` where
    the scene mixes materials) and the run-time values (the volume guard's range)."""

    def __init__(self, units, state, values):
        self.units, self.state, self.values = units, state, values
        self.multi = len(units) > 1

    @ti.func
    def call(self, p, out: ti.template(), method: ti.template(), args: ti.template()):
        """out = unit.method(state, p, *args) of particle p's law (its material's unit)."""
        if ti.static(not self.multi):
            out = ti.static(getattr(self.units[0], method))(self.state, p, *args)
        else:
            for k in ti.static(range(len(self.units))):
                if self.state.mat[p] == k:
                    out = ti.static(getattr(self.units[k], method))(self.state, p, *args)

    @ti.func
    def update(self, p, grad_du, sig_old):
        """New Cauchy stress from the particle's law after the step's displacement gradient
        ``grad_du`` (the law advances the state it owns)."""
        sig_new = sig_old
        self.call(p, sig_new, "update", (grad_du, sig_old))
        return sig_new

    @ti.func
    def stress(self, p, F):
        """sigma(F) of the particle's law (a law whose stress is a function of F)."""
        sig = ti.Matrix.zero(float, self.state.dim, self.state.dim)
        self.call(p, sig, "stress", (F,))
        return sig

    @ti.func
    def reference_volume(self, p):
        """V0_p = m_p / density of the particle's law."""
        vol0 = 0.0
        self.call(p, vol0, "reference_volume", ())
        return vol0

    @ti.func
    def strain_energy(self, p):
        """Particle p's strain energy: W(F_p) V0_p of a hyperelastic law, else the work
        sigma : d_eps V integrated along its path (``work[p]``)."""
        energy = 0.0
        self.call(p, energy, "strain_energy", ())
        return energy

    @ti.func
    def volume_in_range(self, p, vol):
        """volume_min <= V_p / V0 <= volume_max, V0 = m_p / density of the particle's law;
        a law that expands freely (no tension) has no upper bound."""
        ok = True
        self.call(p, ok, "volume_in_range", (vol, self.values.volume_min(),
                                              self.values.volume_max()))
        return ok
