"""Basis functions on a uniform background grid, one file each, and their registry.

Every basis is a class of compile-time constants and one ``@ti.func stencil`` (the
interface: :mod:`.base`): :mod:`.linear` (2.2.3), :mod:`.lagrange` (the quadratic Lagrange
basis of 5.1), :mod:`.bspline` (clamped and uniform B-splines of any degree).  Names are
resolved here, where a name is read (:func:`get_basis`, :func:`basis_argument`): the model,
the scenes and the engine carry the class itself.  :mod:`.sample` evaluates a basis from
Python.
"""
import argparse
import copyreg

from .base import Basis, BasisType
from .bspline import (MAX_BSPLINE_DEGREE, CubicBSpline, QuadraticBSpline, UniformCubicBSpline,
                      UniformQuadraticBSpline, bspline)
from .lagrange import QuadraticLagrange
from .linear import Linear
from .sample import evaluate, stencils

__all__ = ["Basis", "Linear", "QuadraticLagrange", "QuadraticBSpline", "CubicBSpline",
           "UniformQuadraticBSpline", "UniformCubicBSpline", "bspline", "BASES", "get_basis",
           "MAX_BSPLINE_DEGREE", "basis_argument", "evaluate", "stencils"]


def _pickled(cls):
    # a basis pickles by its name (a sweep's worker rebuilds a B-spline of any degree)
    return (get_basis, (cls.name,)) if cls.name else cls.__qualname__


copyreg.pickle(BasisType, _pickled)


BASES: dict[str, type[Basis]] = {cls.name: cls for cls in (
    Linear, QuadraticBSpline, CubicBSpline, QuadraticLagrange, UniformQuadraticBSpline,
    UniformCubicBSpline)}


def get_basis(name: str) -> type[Basis]:
    """Look a basis up by name (``bsplineN`` / ``uniform-bsplineN`` for any degree N),
    with an error that lists the known ones."""
    if isinstance(name, type) and issubclass(name, Basis):
        return name
    if isinstance(name, str) and name not in BASES:
        for prefix, clamped in (("uniform-bspline", False), ("bspline", True)):
            digits = name[len(prefix):]
            if name.startswith(prefix) and digits.isdigit():
                try:
                    return bspline(int(digits), clamped)
                except ValueError as exc:
                    raise ValueError(f"basis {name!r}: {exc}") from None
    try:
        return BASES[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown basis {name!r}: choose one of {', '.join(BASES)} "
            f"(or bsplineN / uniform-bsplineN for degree N = 1 to {MAX_BSPLINE_DEGREE})") from None


def basis_argument(text: str) -> type[Basis]:
    """A command line's basis name, resolved where the parser reads it (before Taichi
    starts or any work): its class, or argparse's error with the known ones."""
    try:
        return get_basis(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
