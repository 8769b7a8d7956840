"""Loads of a model: time functions (each evaluates in Python and inside a kernel) and the
study's traction on one particle (3.5)."""
import math
from dataclasses import dataclass, field

import numpy as np
import taichi as ti

from .checks import positive

__all__ = ["Constant", "Sine", "Ramp", "Traction", "TIME_FUNCTIONS"]


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
        self.omega = float(omega)

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


@dataclass(frozen=True)
class Traction:
    """A force ``amplitude * time_function(t)`` (per unit area) applied on one particle (3.5)."""

    particle: int
    amplitude: float
    time_function: object = field(default_factory=Constant)

    def __post_init__(self):
        if not math.isfinite(float(self.amplitude)):
            raise ValueError(f"traction amplitude must be finite, got {self.amplitude!r}")
        if not callable(getattr(self.time_function, "at", None)):
            raise ValueError("traction time_function must be Constant, Sine, Ramp or alike")


#: the time functions a load may take
TIME_FUNCTIONS = (Constant, Sine, Ramp)
