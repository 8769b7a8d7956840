"""Walls on the sides of a box domain: their kinds and the spec a user gives per side
(:class:`Wall`, :func:`walls_from`); :class:`~timpm.model.Model` takes one per side."""
import math
from dataclasses import dataclass

from ..platform.checks import vector

__all__ = ["Wall", "walls_from", "SIDES", "WALL_KINDS"]

#: the sides of a box, two per axis: x, then y, then z
SIDES = ("left", "right", "bottom", "top", "back", "front")
WALL_KINDS = ("sticky", "slip", "friction", "roller", "periodic")


@dataclass(frozen=True)
class Wall:
    """A wall: ``sticky`` (material touching it is held: no motion, no separation),
    ``slip`` (no penetration, no friction), ``friction`` (Coulomb, coefficient ``mu``) or
    ``roller`` (no normal motion either way, no friction: the symmetry plane and the
    bilateral u_n = 0 of a Dirichlet side); slip and friction walls let the material
    separate.  ``periodic`` on both the left and the right side makes x periodic (no wall:
    the material leaving on one side enters on the other, the grid's last column of nodes
    is its first: an infinite slope, a shear layer).  A sticky wall with a ``velocity``
    (a vector along the wall: the wall stays where it is) drives the material touching it
    at ``velocity`` f(t), f the model's time function ``fixed_time`` (a lid-driven
    cavity, a shear box)."""

    kind: str = "slip"
    mu: float = 0.0
    velocity: tuple | None = None

    def __post_init__(self):
        if self.kind not in WALL_KINDS:
            raise ValueError(f"unknown wall {self.kind!r}: choose one of {', '.join(WALL_KINDS)}")
        mu = float(self.mu)
        if not (math.isfinite(mu) and mu >= 0.0):
            raise ValueError(f"wall friction coefficient must be finite and >= 0, got {self.mu!r}")
        if self.kind != "friction" and mu != 0.0:
            raise ValueError(f"a {self.kind} wall takes no friction coefficient (got mu={mu})")
        object.__setattr__(self, "mu", mu)
        if self.velocity is not None:
            if self.kind != "sticky":
                raise ValueError(f"a {self.kind} wall takes no velocity: a moving wall is "
                                 "sticky (it drives the material touching it)")
            v = tuple(float(c) for c in vector("wall velocity", self.velocity))
            object.__setattr__(self, "velocity", v if any(v) else None)

    @property
    def moves(self) -> bool:
        return self.velocity is not None


def _wall(value, where, open_ok):
    if value is None and open_ok:
        return None
    if isinstance(value, Wall):
        return value
    if isinstance(value, str):
        return Wall(value)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return Wall("friction", value)
    raise ValueError(f"wall {where}: give a Wall, a kind ({', '.join(WALL_KINDS)}) or a "
                     f"friction coefficient{', or None for no wall' if open_ok else ''}, "
                     f"got {value!r}")


def walls_from(spec, dim: int, default="slip", open_ok=False):
    """One wall (or None: no wall, where ``open_ok``) per side of a ``dim``-dimensional
    box from ``spec``: one wall for every side, a dict of side name to wall with an
    optional ``"default"``, or a tuple of one wall per side (what this returns)."""
    sides = SIDES[:2 * dim]
    if isinstance(spec, tuple) and len(spec) == 2 * dim and all(
            w is None or isinstance(w, Wall) for w in spec):
        return tuple(_wall(w, s, open_ok) for w, s in zip(spec, sides))
    if isinstance(spec, dict):
        unknown = set(spec) - set(sides) - {"default"}
        if unknown:
            raise ValueError(f"unknown wall side(s) {sorted(unknown)}: the sides of a "
                             f"{dim}D domain are {', '.join(sides)}")
        default = spec.get("default", default)
        return tuple(_wall(spec.get(s, default), s, open_ok) for s in sides)
    wall = _wall(spec, "for every side", open_ok)
    return (wall,) * (2 * dim)
