"""How one phase of a scheme's step runs (:class:`PhaseRunner`, mixed into
:class:`~timpm.engine.program.Program`; every driver and integrator runs its phases
through it)."""
import taichi as ti

__all__ = ["PhaseRunner"]


class PhaseRunner:
    """Runs one phase over its particles or nodes."""

    @ti.func
    def run_phase(self, phase: ti.template()):
        """One phase of a scheme for every particle or node (``schemes.phases``): its loop
        parallel over the CPU threads, or a part of the one serial task."""
        if ti.static(phase.kind == "scatter"):
            self.scatter_particles(phase)
            if ti.static(self.private_scatter and len(phase.merge) > 0):
                self.merge_copies(phase.merge)
        elif ti.static(phase.kind == "particles"):
            if ti.static(self.on_device):  # to the capacity: no serial task for the bound
                for p in range(self.capacity.particles):
                    if p < self.values.n_particles():
                        phase.particle(self, self.particles, self.grid, self.values, p)
            else:
                for p in range(self.values.n_particles()):
                    phase.particle(self, self.particles, self.grid, self.values, p)
        elif ti.static(phase.kind == "nodes"):
            if ti.static(self.on_device):
                for I in ti.grouped(ti.ndrange(*self.capacity.nodes)):
                    if (I < self.values.nodes()).all():
                        phase.node(self, self.grid, self.values, I)
            else:
                for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k]
                                                 for k in range(self.dim)])):
                    phase.node(self, self.grid, self.values, I)
        else:
            phase.body(self, self.particles, self.grid, self.values)
