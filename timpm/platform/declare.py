"""What a component declares it owns: the fields it keeps per particle or per node
(:class:`Field`) and its parameters (:class:`Param`).

A material law and a transfer scheme each declare theirs in their own file; the engine
allocates the union of the fields a scene's components declare, the model checks the
parameters against their declarations, and the command line, the scene files and the
documentation list them from there.
"""
import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError

__all__ = ["Field", "Param", "check_params"]


@dataclass(frozen=True)
class Field:
    """One entry per particle (or node): ``shape`` "scalar", "vector" (dim entries),
    "matrix" (dim x dim) or a tuple of sizes; ``dtype`` "real" (the run's precision) or
    "int" (32 bits); ``initial`` the value a new scene starts from ("identity" for a
    matrix's I, a number otherwise); ``scratch``: written and read within a step (not part
    of the state that is saved, restored and checkpointed); ``scatter``: a grid field P2G
    adds to (the private scatter keeps a copy of it per thread); ``names``: the names the
    kernels read a grid field by (``grid.node_old_velocity``), where it is not one of the
    engine's (``engine/grid.py``'s ``NODE_NAMES``); ``doc`` what it holds."""

    shape: object = "scalar"
    dtype: str = "real"
    initial: object = 0.0
    doc: str = ""
    scratch: bool = False
    scatter: bool = False
    names: tuple = ()

    def entries(self, dim) -> tuple:
        """The entry's shape in ``dim`` dimensions: () a scalar, (n,) a vector, (n, m)."""
        if self.shape == "scalar":
            return ()
        if self.shape == "vector":
            return (dim,)
        if self.shape == "matrix":
            return (dim, dim)
        return tuple(self.shape)


@dataclass(frozen=True)
class Param:
    """A parameter: its ``default`` (None: required, where the declaration gives the
    default: a scheme's; a law's defaults are its constructor's), ``unit`` ("" for none),
    meaning (``doc``) and range: ``low`` and ``high`` (None: unbounded), open or closed
    (``low_open``, ``high_open``); ``kind`` "real" or "int" (how kernels read it) or
    "bool" (true or false); ``optional``: None is a value (none given)."""

    default: object = None
    unit: str = ""
    doc: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    kind: str = "real"
    optional: bool = False

    def range_text(self) -> str:
        if self.low is None and self.high is None:
            return "a finite number"
        lo = "(" if self.low_open or self.low is None else "["
        hi = ")" if self.high_open or self.high is None else "]"
        return (f"{lo}{'-inf' if self.low is None else f'{self.low:g}'}, "
                f"{'inf' if self.high is None else f'{self.high:g}'}{hi}")

    def check(self, owner: str, name: str, value):
        """``value`` as a float (a bool for a "bool" parameter; None where it is optional
        and none is given), or an InputError naming ``owner``, the parameter, its range and
        the value given (booleans and strings are not numbers, numbers not booleans)."""
        if self.optional and value is None:
            return None
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise InputError(f"{owner}: {name} must be true or false ({self.doc}), got "
                                 f"{value!r}", name)
            return bool(value)
        bad = isinstance(value, (bool, str, np.bool_)) or not isinstance(value, (int, float)) \
            and not hasattr(value, "__float__")
        number = math.nan if bad else float(value)
        ok = math.isfinite(number)
        if ok and self.low is not None:
            ok = number > self.low if self.low_open else number >= self.low
        if ok and self.high is not None:
            ok = number < self.high if self.high_open else number <= self.high
        if not ok:
            unit = f" {self.unit}" if self.unit else ""
            raise InputError(f"{owner}: {name} must be a number in {self.range_text()}{unit}"
                             f" ({self.doc}), got {value!r}", name)
        return number


def check_params(owner: str, declared: dict, given) -> dict:
    """The parameters ``given`` (a dict, or None) checked against ``declared`` (name ->
    Param), the defaults filled in: an unknown name is refused naming the known ones (an
    :class:`~timpm.platform.errors.InputError` about the parameter's name)."""
    given = {} if given is None else given
    if not isinstance(given, dict):
        raise ValueError(f"{owner}: parameters must be a dict of name to number, got "
                         f"{given!r}")
    unknown = [k for k in given if k not in declared]
    if unknown:
        known = ", ".join(declared) if declared else "none"
        raise InputError(f"{owner} has no parameter {unknown[0]!r} (its parameters: {known})",
                         unknown[0])
    out = {}
    for name, param in declared.items():
        if name in given:
            out[name] = param.check(owner, name, given[name])
        elif param.default is None:
            raise InputError(f"{owner}: parameter {name!r} is required ({param.doc})", name)
        else:
            out[name] = float(param.default)
    return out
