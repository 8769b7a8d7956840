"""The four kinds of phase a scheme's step is made of (see :mod:`timpm.schemes`); the
engine runs them (:mod:`timpm.engine.phase_runner`)."""
from dataclasses import dataclass

__all__ = ["Scatter", "Particles", "Nodes", "Whole"]


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
