"""The external forces on a particle and the work they do: gravity, the body force
b(X, t), the study's particle traction (1D), surface tractions spread over a face's
particles and the buoyancy of the saturated particles below a still-water level
(engine/water.py), each time function compiled in (the feature set), its parameter a
run-time value."""
import taichi as ti

__all__ = ["Loads"]


class Loads:
    """See the module: the feature set (which loads act, their time functions), the run
    fields (the time, the external work's sum ``ext_work``) and the add of the mode."""

    def __init__(self, features, run, accumulate, pores):
        f = self.f = features
        self.dim = f.dim
        self.traction_fn, self.surface_fn = f.traction, f.surface_force
        self.run, self.accumulate = run, accumulate
        self.pores = pores  # the buoyancy below a still-water level

    @ti.func
    def force(self, particles: ti.template(), values: ti.template(), p):
        """The particle's external force: m_p (g + b_p) + its tractions at the step's time."""
        mp = particles.m[p]
        fp = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            if ti.static(self.f.gravity[k]):
                fp[k] += mp * values.gravity()[k]
        if ti.static(self.f.has_traction):
            if p == values.traction_particle():
                fp[0] += values.traction_amplitude() * self.traction_fn.at(
                    self.run.time[None], values.traction_param())
        if ti.static(self.f.body_force):
            fp += mp * particles.b[p]
        if ti.static(self.f.has_surface_force):
            fp += particles.f_ext[p] * self.surface_fn.at(self.run.time[None],
                                                          values.surface_param())
        if ti.static(self.f.water_level):
            fp += self.pores.buoyancy(particles, p)
        return fp

    @ti.func
    def record_work(self, particles: ti.template(), values: ti.template(), p, du):
        """The work of the particle's tractions, body force and surface forces over its
        displacement ``du`` this step, added to the run's external work."""
        if ti.static(self.f.has_traction):
            if p == values.traction_particle():
                self.add_work(values.traction_amplitude()
                              * self.traction_fn.at(self.run.time[None], values.traction_param())
                              * du[0])
        if ti.static(self.f.body_force):
            self.add_work(particles.m[p] * particles.b[p].dot(du))
        if ti.static(self.f.has_surface_force):
            f_t = self.surface_fn.at(self.run.time[None], values.surface_param())
            self.add_work(f_t * particles.f_ext[p].dot(du))
        if ti.static(self.f.water_level):
            self.add_work(self.pores.buoyancy(particles, p).dot(du))

    @ti.func
    def add_work(self, work):
        """The run's record of the external forces' work += work (energies recorded)."""
        self.accumulate(self.run.ext_work[None], work)
