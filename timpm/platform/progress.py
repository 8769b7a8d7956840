"""A one-line progress bar on stderr for runs longer than a couple of seconds."""
import sys
import time

__all__ = ["Progress"]


class Progress:
    """A one-line progress bar on stderr for runs longer than a couple of seconds."""

    def __init__(self, total, enabled, bounded=False):
        # bounded: chunks of about half a second even without a bar (a run that must
        # notice Ctrl-C within a second)
        self.total, self.enabled, self.bounded = max(int(total), 1), enabled, bounded
        self.start = time.perf_counter()
        self.shown = False

    def suggested_chunk(self, done):
        # small first chunks let the bar appear; later chunks cover about half a second
        if self.enabled is False and not self.bounded:
            return self.total
        elapsed = time.perf_counter() - self.start
        if done == 0 or elapsed <= 0:
            return max(1, min(self.total, 2000))
        return max(1, int(done / elapsed * 0.5))

    def update(self, done):
        if self.enabled is False:
            return
        elapsed = time.perf_counter() - self.start
        if self.enabled is None and (elapsed < 2.0 or not sys.stderr.isatty()):
            return
        frac = done / self.total
        eta = elapsed / max(frac, 1e-12) - elapsed
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r[{bar:<30}] {100 * frac:5.1f}%  {elapsed:6.1f} s  eta {eta:6.1f} s")
        sys.stderr.flush()
        self.shown = True

    def close(self):
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()
