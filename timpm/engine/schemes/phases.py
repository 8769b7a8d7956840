"""The four kinds of phase a scheme's step is made of (see :mod:`timpm.engine.schemes`),
and how one runs (:class:`PhaseRunner`, mixed into :class:`~timpm.engine.program.Program`;
every driver and integrator runs its phases through it)."""
from dataclasses import dataclass

import taichi as ti

__all__ = ["Scatter", "Particles", "Nodes", "Whole", "PhaseRunner"]


@dataclass(frozen=True)
class Scatter:
    """A particle loop adding to the grid by the scatter strategy: ``particle(program,
    particles, grid, values, p, copy) -> (stencil base, inside, node values)``; ``rows``:
    the grid fields it adds to (the 1D run sums' rows); ``merge``: the private copies
    summed into the grid after it."""
    label: str
    particle: object
    rows: tuple = ()
    merge: tuple = ()
    kind: str = "scatter"


@dataclass(frozen=True)
class Particles:
    """A loop over the particles: ``particle(program, particles, grid, values, p)``."""
    label: str
    particle: object
    kind: str = "particles"


@dataclass(frozen=True)
class Nodes:
    """A loop over the live grid nodes: ``node(program, grid, values, I)``."""
    label: str
    node: object
    kind: str = "nodes"


@dataclass(frozen=True)
class Whole:
    """A phase with its own loops, ``body(program, particles, grid, values)`` (no team
    runs it)."""
    label: str
    body: object
    kind: str = "whole"


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
