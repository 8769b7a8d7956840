"""Named error codes of a run, and the exceptions timpm raises."""
import contextlib
import enum

__all__ = ["ErrorCode", "SimulationError", "Released", "InputError", "about",
           "TEAM_SPIN_LIMIT"]

#: spins of a team barrier (an atomic read each, tens of ns) before the step gives up
TEAM_SPIN_LIMIT = 1 << 29


class ErrorCode(enum.IntEnum):
    """What stopped a run; the kernels record the code of the first failure."""

    OFF_GRID = 1
    NOT_FINITE = 2
    INVERTED = 3
    SINGULAR_MASS = 4
    ENERGY_GROWTH = 5
    TEAM_BARRIER = 6
    VOLUME_RANGE = 7
    MASS_SOLVE = 8
    MIDPOINT = 9

    @property
    def message(self) -> str:
        return _MESSAGES[self]


_MESSAGES = {
    ErrorCode.OFF_GRID: "left the grid",
    ErrorCode.NOT_FINITE: "has a non-finite (NaN or infinite) state",
    ErrorCode.INVERTED: "has a non-positive volume (the material inverted)",
    ErrorCode.SINGULAR_MASS: "the consistent mass matrix is singular",
    ErrorCode.ENERGY_GROWTH: "energy grew without a source",
    ErrorCode.TEAM_BARRIER: "the threads of a team step did not meet at a barrier",
    ErrorCode.VOLUME_RANGE: "was crushed or torn apart: its volume left the allowed range",
    ErrorCode.MASS_SOLVE: "the consistent mass solve (conjugate gradients) did not converge",
    ErrorCode.MIDPOINT: "the midpoint integrator's iteration did not converge",
}

#: code -> message, as the kernels record it
ERRORS = {int(code): code.message for code in ErrorCode}


class SimulationError(RuntimeError):
    """A run stopped because the state became invalid; the message names step and where."""

    def __init__(self, message, code=0, step=-1, particle=-1, node=-1):
        super().__init__(message)
        self.code, self.step, self.particle, self.node = code, step, particle, node


class Released(RuntimeError):
    """A solver or batch used after ``release()`` or after a Taichi restart freed it."""


class InputError(ValueError):
    """A value refused, naming the argument it is about: ``key``, the keyword of the
    constructor or function that received it (``"dt"``, ``"transfer_params"``,
    ``"bodies[2]"``), for the front end that read it (a scene file names its own key
    and line from it)."""

    def __init__(self, message, key=None):
        super().__init__(message)
        self.key = key


@contextlib.contextmanager
def about(key, rename=None):
    """Inside, a ValueError becomes an :class:`InputError` about ``key``; one that names
    its key already keeps it (``rename``: a dict that maps such keys to the caller's own,
    the keywords of a Model to those of the World that built it)."""
    try:
        yield
    except InputError as err:
        if rename is not None and err.key in rename:
            raise InputError(str(err), rename[err.key]) from None
        if err.key is None:
            raise InputError(str(err), key) from None
        raise
    except ValueError as err:
        raise InputError(str(err), key) from None
