"""The kinds of phase a scheme's step is made of (see :mod:`timpm.schemes`); the engine's
drivers run them (:mod:`timpm.engine.drivers`).

A phase in a :class:`Repeat` is ``staged``: its function also receives the repeat's index
``s`` (a run-time loop in the fused serial mode, a launch each in the parallel mode).
"""
from dataclasses import dataclass

__all__ = ["Scatter", "Particles", "Nodes", "Whole", "Repeat"]


@dataclass(frozen=True)
class Scatter:
    """A particle loop adding to the grid by the scatter strategy: ``particle(particles,
    grid, values, p, copy) -> (stencil base, inside, node values)``; ``rows``: the grid
    fields it adds to (the 1D run sums' rows); ``merge``: the private copies summed into the
    grid after it."""
    label: str
    particle: object
    rows: tuple = ()
    merge: tuple = ()
    kind: str = "scatter"


@dataclass(frozen=True)
class Particles:
    """A loop over the particles: ``particle(particles, grid, values, p[, s])``."""
    label: str
    particle: object
    staged: bool = False
    kind: str = "particles"


@dataclass(frozen=True)
class Nodes:
    """A loop over the live grid nodes: ``node(grid, values, I[, s])``."""
    label: str
    node: object
    staged: bool = False
    kind: str = "nodes"


@dataclass(frozen=True)
class Whole:
    """A phase with its own loops, ``body(particles, grid, values[, s])`` (no team runs
    it)."""
    label: str
    body: object
    staged: bool = False
    kind: str = "whole"


@dataclass(frozen=True)
class Repeat:
    """``phases`` (staged) run ``count`` times, s = 0 .. count - 1, within one step (no
    team runs it)."""
    label: str
    count: int
    phases: tuple
    kind: str = "repeat"
