"""A few results kept by what they were computed from: a World built again from the same
particles (a strength-reduction trial's reduced soil, a Monte Carlo realisation's trial)
computes its random field and its geostatic stress once.  NumPy only."""
import hashlib
from collections import OrderedDict

import numpy as np

__all__ = ["Memo", "digest"]


def digest(array) -> tuple:
    """A key for an array's values: its shape, dtype and a hash of its bytes."""
    a = np.ascontiguousarray(array)
    return a.shape, a.dtype.str, hashlib.blake2b(a.tobytes(), digest_size=16).digest()


class Memo:
    """The ``kept`` most recent results of ``compute()`` by ``key`` (a hashable tuple).
    The arrays of a result kept are made read-only: every caller shares them."""

    def __init__(self, kept: int = 4):
        self.kept = kept
        self._results: OrderedDict = OrderedDict()

    def get(self, key, compute):
        try:
            hash(key)
        except TypeError:  # (a part of the inputs without a value's hash: not kept)
            return compute()
        if key in self._results:
            self._results.move_to_end(key)
            return self._results[key]
        out = compute()
        for v in (out.values() if isinstance(out, dict) else [out]):
            if isinstance(v, np.ndarray):
                v.setflags(write=False)
        self._results[key] = out
        while len(self._results) > self.kept:
            self._results.popitem(last=False)
        return out
