"""Ctrl-C (SIGINT), and a scheduler's SIGTERM or a closed terminal's SIGHUP, as a request
to stop at the next step boundary.

Inside ``with deferred_sigint():`` the first of these signals only sets a flag, which a run
loop reads between its launches (:func:`requested`): the run stops with its state whole,
so that it can be saved, and the command exits with 128 + the signal's number (130 for
Ctrl-C, 143 for SIGTERM, 129 for SIGHUP; :func:`exit_code`).  A second signal raises
``KeyboardInterrupt`` at once, as Python does by default for SIGINT.  Outside the block,
or off the main thread, or for a signal whose handler the program has replaced or that
the shell left ignored (a background job's SIGINT in a script, ``cmd & wait``; nohup's
SIGHUP), nothing changes: the others are still deferred.
"""
import contextlib
import signal
import threading

__all__ = ["deferred_sigint", "requested", "active", "RunInterrupted", "exit_code",
           "termination_as_interrupt", "INTERRUPTED_CHECKPOINT", "SIGNALS"]

#: the signals a run stops on at a step boundary (those this platform has)
SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                if hasattr(signal, name))

#: where the command line saves a run that Ctrl-C stopped, given no --checkpoint
INTERRUPTED_CHECKPOINT = "timpm-interrupted.npz"

_state = {"active": False, "requested": False, "signal": signal.SIGINT}


class RunInterrupted(Exception):
    """A run stopped at a step boundary because Ctrl-C was pressed; ``step`` and ``t``
    say where.  ``result`` and ``checkpoint`` are set by the driver that caught it (the
    partial record, the file the state was saved to)."""

    def __init__(self, step, t):
        self.signal = _state["signal"]
        by = "" if self.signal == signal.SIGINT else f" by {signal.Signals(self.signal).name}"
        super().__init__(f"interrupted{by} at step {step} (t = {t:g} s)")
        self.step, self.t = step, t
        self.result = None
        self.checkpoint = None

    @property
    def exit_code(self) -> int:
        """128 + the signal's number: 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP."""
        return 128 + int(self.signal)


def active() -> bool:
    """Whether a SIGINT is now deferred (run loops then keep their launches short)."""
    return _state["active"]


def requested() -> bool:
    """Whether Ctrl-C was pressed since the deferral began."""
    return _state["requested"]


def exit_code() -> int:
    """128 + the number of the last signal that stopped a run (130: Ctrl-C)."""
    return 128 + int(_state["signal"])


def _handler(signum, frame):
    if _state["requested"]:
        raise KeyboardInterrupt  # the second signal: at once
    _state.update(requested=True, signal=signum)


@contextlib.contextmanager
def deferred_sigint():
    """Defer SIGINT, SIGTERM and SIGHUP to the next step boundary for the duration of the
    block (each whose handler is still Python's default)."""
    defaults = {signal.SIGINT: signal.default_int_handler}
    usable = threading.current_thread() is threading.main_thread() and not _state["active"]
    taken = [s for s in SIGNALS if usable and signal.getsignal(s) in (
        defaults.get(s, signal.SIG_DFL), _raise_interrupt)]  # (ours: termination_as_interrupt)
    if not taken:  # (a signal the shell left ignored stays ignored: a background job's
        yield      # SIGINT, nohup's SIGHUP; the others are still taken)
        return
    previous = {s: signal.signal(s, _handler) for s in taken}
    _state.update(active=True, requested=False, signal=signal.SIGINT)
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        _state.update(active=False, requested=False)


def _raise_interrupt(signum, frame):
    _state["signal"] = signum
    raise KeyboardInterrupt


@contextlib.contextmanager
def termination_as_interrupt():
    """SIGTERM and SIGHUP raise ``KeyboardInterrupt`` in the block, as Ctrl-C does, so that
    a command's cleanup runs (a sweep stops its workers and releases their semaphores)
    instead of the process dying where it stands; :func:`exit_code` then gives 128 + the
    signal.  Off the main thread, or where a handler is installed already, nothing
    changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    taken = [s for s in SIGNALS if s != signal.SIGINT
             and signal.getsignal(s) is signal.SIG_DFL]
    previous = {s: signal.signal(s, _raise_interrupt) for s in taken}
    _state["signal"] = signal.SIGINT
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
