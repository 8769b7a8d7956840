"""Checks of user values shared by the model's builders, the solver and the drivers, each
error naming the value; the limits on a run's steps and on a scene's size."""
import math
import numbers
import os

import numpy as np

__all__ = ["positive", "positive_int", "vector", "matrices", "finite", "is_whole", "whole",
           "distinct", "index", "solver_options", "MAX_STEPS", "MAX_INDEX", "step_count",
           "check_steps", "available_memory", "state_bytes", "check_size"]


def positive(name: str, value) -> float:
    """``value`` as a positive finite float."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return value


def positive_int(name: str, value) -> int:
    """``value`` as a positive int (a bool, a float or a string is refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def vector(name: str, value, dim=None) -> np.ndarray:
    """``value`` as a finite float vector, of ``dim`` components where given."""
    try:
        v = np.array(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence of numbers, got {value!r}") from None
    if dim is not None and len(v) != dim:
        raise ValueError(f"{name} must have {dim} components, got {len(v)}: {value!r}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def matrices(name: str, value, n: int, dim: int) -> np.ndarray:
    """``value`` as ``n`` finite float ``dim`` x ``dim`` matrices (n of them, or one for
    all); the errors say what ``name`` takes."""
    shape = (n, dim, dim)
    try:
        m = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} takes numbers, got {value!r}") from None
    if m.shape not in (shape, shape[1:]):
        raise ValueError(f"{name} takes one {dim}x{dim} matrix or {shape} "
                         f"matrices, got an array of shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError(f"{name} takes finite values, got NaN or infinity")
    return np.broadcast_to(m, shape).copy()


def finite(name: str, value) -> float:
    """``value`` as a finite float (a bool or a string is refused)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) \
            or not math.isfinite(float(value)):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def is_whole(value) -> bool:
    """An integer, or a float with an integral value (not a bool, a string, 2.5)."""
    return (not isinstance(value, bool) and isinstance(value, numbers.Real)
            and float(value).is_integer())


def whole(name: str, value, minimum: int = 1) -> int:
    """``value`` as an int of at least ``minimum``: an integer, or a float with a whole
    value (2.0 from a command line; 2.5, a bool or a string is refused)."""
    if not is_whole(value) or value < minimum:
        kind = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise ValueError(f"{name} must be {kind}, got {value!r}")
    return int(value)


def distinct(name: str, values, why: str = "") -> None:
    """Refuse a list that names a value more than once (``why`` follows the message)."""
    values = list(values)
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise ValueError(f"{name} lists {', '.join(map(str, repeated))} more than once"
                         + (f": {why}" if why else ""))


def index(name: str, value) -> int:
    """``value`` (an integer, or a float with a whole value) as an int index."""
    if not is_whole(value):
        raise ValueError(f"{name} must be an integer index, got {value!r}")
    return int(value)


def solver_options(energies, energy_guard, serial_threshold, small_mass) -> None:
    """The Solver's flags and numbers, each error naming the option."""
    if not isinstance(energies, (bool, np.bool_)):
        raise ValueError(f"energies must be True or False, got {energies!r}")
    if energy_guard is not None:
        if isinstance(energy_guard, bool) or not isinstance(energy_guard, numbers.Real) \
                or not (1.0 <= energy_guard < np.inf):
            raise ValueError(f"energy_guard must be a finite number >= 1 (the factor by which "
                             f"kinetic + strain energy may exceed the energy supplied) or "
                             f"None, got {energy_guard!r}")
    if not is_whole(serial_threshold) or serial_threshold < 0:
        raise ValueError(f"serial_threshold must be a non-negative integer (particles), got "
                         f"{serial_threshold!r}")
    if isinstance(small_mass, bool) or not isinstance(small_mass, numbers.Real) \
            or not (0.0 <= small_mass < np.inf):
        raise ValueError(f"small_mass must be a finite number >= 0, got {small_mass!r}")


# ---- how long a run takes and how much memory a scene needs --------------------------------

#: a run of more steps is refused unless allowed (allow_many_steps=True,
#: --allow-many-steps): 1e8 steps take minutes even for the smallest 1D scene (about
#: 1 microsecond a step), hours for a 2D demo; more is a mistaken dt or t_end
MAX_STEPS = 10 ** 8

#: Taichi indexes fields with 32-bit integers: no more particles or nodes than this
MAX_INDEX = 2 ** 31 - 1


def step_count(t_end, dt, allow_many_steps=False) -> int:
    """The number of steps of size ``dt`` that reach ``t_end`` from 0 (rounded to the
    nearest step), refused above :data:`MAX_STEPS` unless ``allow_many_steps``."""
    t_end = finite("t_end", t_end)
    if t_end < 0.0:
        raise ValueError(f"t_end must be a non-negative finite time, got {t_end!r}")
    steps = t_end / dt
    check_steps(steps, dt, allow_many_steps, t_end=t_end)
    return int(round(steps))


def check_steps(steps, dt, allow_many_steps=False, t_end=None) -> None:
    """Refuse a run of more than :data:`MAX_STEPS` steps unless ``allow_many_steps`` (and
    one of more steps than can be counted in any case)."""
    if steps <= MAX_STEPS or (allow_many_steps and steps < 2 ** 62):
        return
    span = f"to t_end = {t_end:g} s " if t_end is not None else ""
    raise ValueError(
        f"a run {span}at dt = {dt:g} s takes {steps:.3g} steps, more than the "
        f"{MAX_STEPS:.0e} a run may take unless allowed: choose a larger dt or a shorter "
        "run, or pass allow_many_steps=True (--allow-many-steps) to run it anyway")


#: the memory limit of this process's control group (v2, v1), where one is set
_CGROUP_LIMITS = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes")


def available_memory():
    """Bytes of memory this process may still take: MemAvailable of /proc/meminfo (else
    the free physical pages), at most the memory limit of its control group (a
    container's); None where neither is known."""
    free = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    free = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if free is None:
        try:
            free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, OSError, ValueError):
            pass
    for path in _CGROUP_LIMITS:
        try:
            with open(path) as f:
                limit = int(f.read())  # "max" (no limit) is no int
        except (OSError, ValueError):
            continue
        if limit < 1 << 60:  # v1 writes no limit as a huge number
            free = limit if free is None else min(free, limit)
        break
    return free


def state_bytes(particles: int, nodes: int, dim: int) -> int:
    """The least memory the state of a scene takes: (dim + 2)^2 doubles per particle
    (position, velocity, stress, volume and mass in the engine, dim^2 + 2 dim + 2; the
    model's positions, velocities, volumes and masses, 2 dim + 2) and dim + 2 doubles per
    grid node (its mass and momentum among them).  Every feature set takes at least
    this (``Solver.memory()``: 60 to 296 B a particle, 28 to 56 B a node)."""
    return 8 * (dim + 2) * ((dim + 2) * int(particles) + int(nodes))


def _size(n) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def check_size(what: str, particles, nodes, dim: int) -> None:
    """Refuse, before anything is allocated, a scene of ``particles`` particles and
    ``nodes`` grid nodes in ``dim`` dimensions that Taichi cannot index or that needs
    more memory (:func:`state_bytes`) than the machine has available; ``what`` names the
    scene and where its size comes from."""
    particles, nodes = int(particles), int(nodes)
    for count, name in ((particles, "particles"), (nodes, "grid nodes")):
        if count > MAX_INDEX:
            raise ValueError(f"{what}: {count:.3g} {name}, more than the {MAX_INDEX} Taichi "
                             "can index")
    need, free = state_bytes(particles, nodes, dim), available_memory()
    if free is not None and need > free:
        raise ValueError(
            f"{what}: {particles:.3g} particles and {nodes:.3g} grid nodes need at least "
            f"{_size(need)} ({8 * (dim + 2) ** 2} B a particle, {8 * (dim + 2)} B a node), "
            f"more than the {_size(free)} of memory available")


def shown_point(x):
    """A point for a message: a float in 1D, a tuple of floats beyond."""
    return float(x[0]) if len(x) == 1 else tuple(float(c) for c in x)
