"""The process's programs: one per feature set (and Batch slot), at a capacity that grows.

:func:`program_for` hands a solver the :class:`~timpm.engine.program.Program` of its
feature set, built and compiled on first use; a scene larger than the program's
:class:`Capacity` grows it (doubling), which builds a new program and compiles again:
log2 of the size range at most.  The programs of an earlier Taichi start are forgotten
(their fields went with it).
"""
from dataclasses import dataclass

from .program import Program

__all__ = ["Capacity", "program_for", "release_state_of", "clear_programs"]


@dataclass(frozen=True)
class Capacity:
    """How much a program's fields hold."""

    particles: int
    nodes: tuple
    tracked: int
    history: int

    def holds(self, layout) -> bool:
        return (layout.n_particles <= self.particles and layout.n_tracked <= self.tracked
                and layout.history <= self.history
                and all(n <= c for n, c in zip(layout.room, self.nodes)))

    def grown(self, layout) -> "Capacity":
        """A capacity that holds ``layout``: every size too small doubles (at least),
        but the grid axes of 2D and 3D grow to what is needed (doubling each axis of a 3D
        grid would take eight times its memory)."""
        def grow(have, need, factor=2):
            return have if need <= have else max(need, factor * have)
        axis = 2 if len(self.nodes) == 1 else 1
        return Capacity(grow(self.particles, layout.n_particles),
                        tuple(grow(c, n, axis) for c, n in zip(self.nodes, layout.room)),
                        grow(self.tracked, layout.n_tracked),
                        grow(self.history, layout.history))

    @staticmethod
    def first(features, layout) -> "Capacity":
        """The first capacity of a feature set: room for a 1D study's meshes (1024 particles,
        2064 nodes: 1024 quadratic Lagrange elements), a 2D or 3D one's (16384 particles and
        72^2 nodes, 32768 and 40^3: a few MiB), or the scene's own sizes where larger: each
        larger capacity compiles the program again."""
        if features.dim == 1:
            return Capacity(max(1024, layout.n_particles), (max(2064, layout.room[0]),),
                            max(8, layout.n_tracked), max(1024, layout.history))
        particles, axis = (16384, 72) if features.dim == 2 else (32768, 40)
        return Capacity(max(particles, layout.n_particles),
                        tuple(max(axis, n) for n in layout.room), max(8, layout.n_tracked),
                        layout.history)


_PROGRAMS: dict = {}


def program_for(features, layout, slot: int = 0):
    """The process's program of ``features`` (``slot``: another copy, for a Batch), grown
    to hold ``layout``; built and compiled on first use."""
    from ..platform import runtime

    runtime.check_caller()
    for old in [k for k in _PROGRAMS if k[2] != runtime.generation()]:
        del _PROGRAMS[old]  # Taichi restarted: their fields are gone with it
    key = (features, slot, runtime.generation())
    prog = _PROGRAMS.get(key)
    if prog is not None and prog.capacity.holds(layout):
        return prog
    if prog is None:
        cap = Capacity.first(features, layout)
    else:
        cap = prog.capacity.grown(layout)
        owner = prog.active
        if owner is not None:
            owner.save_to_host(prog)
        prog.release()
    prog = Program(features, cap)
    _PROGRAMS[key] = prog
    return prog


def release_state_of(owner):
    """Forget ``owner``'s state in every program that holds it (a released solver: its
    state is not saved)."""
    for prog in list(_PROGRAMS.values()):
        prog.deactivate(owner)


def clear_programs():
    """Free every program's fields and forget the compiled kernels: the state a program
    holds is saved to its solver first, and a solver used again uploads it into a new
    program (compiled again)."""
    from ..platform import runtime

    for (_, _, gen), prog in _PROGRAMS.items():
        if gen == runtime.generation():  # else Taichi freed them at its restart
            owner = prog.active
            if owner is not None:
                owner.save_to_host(prog)
            prog.release()
    _PROGRAMS.clear()
