"""Ctrl-C (SIGINT) as a request to stop at the next step boundary.

Inside ``with deferred_sigint():`` the first SIGINT only sets a flag, which a run loop
reads between its launches (:func:`requested`): the run stops with its state whole, so
that it can be saved.  A second SIGINT raises ``KeyboardInterrupt`` at once, as Python
does by default.  Outside the block, or off the main thread, or where the program has
installed its own SIGINT handler, nothing changes.
"""
import contextlib
import signal
import threading

__all__ = ["deferred_sigint", "requested", "active", "RunInterrupted",
           "INTERRUPTED_CHECKPOINT"]

#: where the command line saves a run that Ctrl-C stopped, given no --checkpoint
INTERRUPTED_CHECKPOINT = "timpm-interrupted.npz"

_state = {"active": False, "requested": False}


class RunInterrupted(Exception):
    """A run stopped at a step boundary because Ctrl-C was pressed; ``step`` and ``t``
    say where.  ``result`` and ``checkpoint`` are set by the driver that caught it (the
    partial record, the file the state was saved to)."""

    def __init__(self, step, t):
        super().__init__(f"interrupted at step {step} (t = {t:g} s)")
        self.step, self.t = step, t
        self.result = None
        self.checkpoint = None


def active() -> bool:
    """Whether a SIGINT is now deferred (run loops then keep their launches short)."""
    return _state["active"]


def requested() -> bool:
    """Whether Ctrl-C was pressed since the deferral began."""
    return _state["requested"]


def _handler(signum, frame):
    if _state["requested"]:
        raise KeyboardInterrupt  # the second Ctrl-C: at once
    _state["requested"] = True


@contextlib.contextmanager
def deferred_sigint():
    """Defer SIGINT to the next step boundary for the duration of the block."""
    usable = (threading.current_thread() is threading.main_thread()
              and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    if not usable or _state["active"]:
        yield
        return
    previous = signal.signal(signal.SIGINT, _handler)
    _state.update(active=True, requested=False)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        _state.update(active=False, requested=False)
