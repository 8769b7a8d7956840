"""Loads of a model: time functions (each evaluates in Python and inside a kernel), the
study's traction on one particle (3.5), body forces b(X, t) given as Python functions and
surface tractions on the faces of 2D and 3D bodies."""
import inspect
from dataclasses import dataclass, field

import numpy as np
import taichi as ti

from ..platform.checks import finite, positive, whole

__all__ = ["Constant", "Sine", "Ramp", "Traction", "BodyForce", "SurfaceTraction",
           "field_function", "time_function", "TIME_FUNCTIONS"]


@ti.data_oriented
class Constant:
    """f(t) = 1 for t >= 0 (a step load, H(t))."""

    def __call__(self, t):
        return np.ones_like(np.asarray(t, dtype=float))

    #: the run-time parameter of ``at`` (none)
    param = 0.0

    @staticmethod
    @ti.func
    def at(t, a):
        """f(t) in a kernel, the parameter ``a`` read at run time."""
        return 1.0

    def __repr__(self):
        return "Constant()"


@ti.data_oriented
class Sine:
    """f(t) = sin(omega t)."""

    def __init__(self, omega: float):
        self.omega = finite("Sine omega", omega)

    def __call__(self, t):
        return np.sin(self.omega * np.asarray(t, dtype=float))

    @property
    def param(self):
        return self.omega

    @staticmethod
    @ti.func
    def at(t, a):
        return ti.sin(a * t)

    def __repr__(self):
        return f"Sine(omega={self.omega!r})"


@ti.data_oriented
class Ramp:
    """f(t) = min(t / duration, 1): a load brought on smoothly."""

    def __init__(self, duration: float):
        self.duration = positive("ramp duration", duration)

    def __call__(self, t):
        return np.minimum(np.asarray(t, dtype=float) / self.duration, 1.0)

    @property
    def param(self):
        return self.duration

    @staticmethod
    @ti.func
    def at(t, a):
        return ti.min(t / a, 1.0)

    def __repr__(self):
        return f"Ramp(duration={self.duration!r})"


def time_function(name: str, value):
    """``value`` as the time function of a load: Constant() for None, else an object with a
    kernel ``at(t, param)`` (Constant, Sine, Ramp or alike); an error names ``name``."""
    if value is None:
        return Constant()
    if not callable(getattr(value, "at", None)):
        raise ValueError(f"{name} must be a time function (Constant, Sine, Ramp), got "
                         f"{value!r}")
    return value


@dataclass(frozen=True)
class Traction:
    """A force ``amplitude * time_function(t)`` (per unit area) applied on one particle (3.5)."""

    particle: int
    amplitude: float
    time_function: object = field(default_factory=Constant)

    def __post_init__(self):
        object.__setattr__(self, "particle", whole("traction particle", self.particle, 0))
        object.__setattr__(self, "amplitude", finite("traction amplitude", self.amplitude))
        time_function("traction time_function", self.time_function)


#: the time functions a load may take
TIME_FUNCTIONS = (Constant, Sine, Ramp)


def _takes(fn, what, want):
    """None if ``fn`` can be called with ``want`` positional arguments (or its signature is
    unknown), else the number it takes; an error names ``what`` if it is no function."""
    if not callable(fn):
        raise ValueError(f"{what} must be a function, got {fn!r}")
    try:
        params = list(inspect.signature(fn).parameters.values())
    except (TypeError, ValueError):  # a builtin or ufunc without a signature: trust it
        return None
    if any(p.kind == p.VAR_POSITIONAL for p in params):
        return None
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    required = sum(p.default is p.empty for p in positional)
    return None if required <= want <= len(positional) else required


def _check_arity(fn, what, want, points):
    """An error naming ``what`` unless ``fn`` takes ``want`` positional arguments: the
    ``points`` positions X (``"(n, 2)"``), and the time t when ``want`` is 2."""
    arity = _takes(fn, what, want)
    if arity is not None:
        count, names = (("one argument", "(X)") if want == 1 else
                        ("two arguments", "(X, t)"))
        raise ValueError(f"{what} must take {count} {names}: the {points} positions"
                         f"{' and the time' if want == 2 else ''}; "
                         f"{getattr(fn, '__name__', fn)!s} takes {arity}")


def field_function(fn, X, what, *args, signature=True):
    """``fn(X, *args)`` for the (n, dim) points X as an (n, dim) float array, checked: a
    function of the points (and ``args``), vectorised over them, finite everywhere.  In
    1D a result of shape (n,) is taken as (n, 1).  The error names ``what``, the first
    bad point and the value there (``signature=False``: the parameters were checked
    already)."""
    n, dim = X.shape
    if signature:
        _check_arity(fn, what, 1 + len(args), f"(n, {dim})")
    try:
        out = fn(X.copy(), *args)
    except Exception as err:
        raise ValueError(f"{what} failed on the (n, {dim}) array of points: "
                         f"{type(err).__name__}: {err}") from err
    try:
        out = np.array(out, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must return numbers, got {type(out).__name__}") from None
    if dim == 1 and out.shape == (n,):
        out = out.reshape(n, 1)
    if out.shape != (n, dim):
        raise ValueError(f"{what} must return an (n, {dim}) array for n = {n} points "
                         f"(one value per point and axis, vectorised), got shape {out.shape}")
    finite = np.all(np.isfinite(out), axis=1)
    if not finite.all():
        p = int(np.flatnonzero(~finite)[0])
        at = ", ".join(f"{c:g}" for c in X[p])
        raise ValueError(f"{what} is not finite at point {p} (X = ({at})"
                         + (f", t = {args[0]:g}" if args else "") + f"): {out[p].tolist()}")
    return out


@dataclass(frozen=True, eq=False)
class BodyForce:
    """A body force per unit mass b(X, t) (an acceleration, m/s^2) given as a Python
    function ``fn(X, t)`` of the particles' reference positions X (an (n, dim) array) and
    the time, vectorised: it returns the (n, dim) values of all particles at once (n
    values in 1D).  The solver calls it once per step, at the step's start time, and
    uploads the values (one call per step, none per particle).  ``frame="current"`` passes
    the particles' current positions x instead of X (read back every step).  Its work
    enters the recorded external work.  A model evaluates it at t = 0 when built: a wrong
    signature, shape or a non-finite value is an error naming the point."""

    fn: object
    frame: str = "reference"

    def __post_init__(self):
        if self.frame not in ("reference", "current"):
            raise ValueError(f"body force frame must be 'reference' or 'current', got "
                             f"{self.frame!r}")
        _check_arity(self.fn, "the body force", 2, "(n, dim)")

    def __call__(self, X, t):
        """b at points X (n, dim) and time t, checked: an (n, dim) float array."""
        return field_function(self.fn, np.asarray(X, dtype=np.float64), "the body force",
                              float(t), signature=False)


@dataclass(frozen=True)
class SurfaceTraction:
    """A traction (force per unit area, a vector) ``traction * time_function(t)`` on the
    ``side`` face (``"left"``, ``"right"``, ``"bottom"``, ``"top"``, ``"back"``,
    ``"front"``) of body ``body`` of a :class:`timpm.model.world.World` in 2D or 3D.  The
    particles within half a particle spacing of the body's extreme on that side carry it:
    each the force traction * V_p / dx, dx = h / ppc the spacing normal to the face, so
    that the forces sum to traction times the face's area (length in 2D, per unit depth)."""

    body: int
    side: str
    traction: tuple
    time_function: object = field(default_factory=Constant)

    def __post_init__(self):
        from ..platform.checks import vector

        object.__setattr__(self, "traction", tuple(vector("surface traction", self.traction)))
        time_function("surface traction time_function", self.time_function)
