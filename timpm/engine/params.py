"""Run-time values of a compiled program, read in kernels by getter.

The kernels of a :class:`~timpm.engine.program.Program` are compiled for a feature set,
not for a scene: everything that differs between scenes of one feature set (sizes, grid
spacing, time step, loads, material constants) is a run-time value held here.  Kernel
code reads ``self.values.dt()``; Python sets the values of a scene and uploads them all at
once (two copies: the floats and the integers).  Every value that per-scene kernels
would fold from Python floats (``dt * D_inv``, ``1 / h``, a material's derived
constants) is computed once in Python and stored, so the kernels see the same numbers.
"""
import numpy as np
import taichi as ti

from .expressions import at, expression

__all__ = ["ParamBlock"]


def _scalar(arr, i):
    # the load arr[i] where the getter is called (expressions.py)
    return expression(lambda: at(arr, i))


def _vector(arr, i, n):
    return expression(lambda: ti.Vector([at(arr, i + k) for k in range(n)]))


class Group:
    """The getters of one group of values (``group.dt()`` in a kernel)."""

    def __init__(self, name):
        self._name = name


class ParamBlock:
    """Values declared as ``{group: {name: kind}}`` with kind ``"real"``, ``"int"``,
    ``("real", n)`` or ``("int", n)`` (vectors of n), held in one float and one integer
    field.  ``block.groups[group]`` holds the getters."""

    def __init__(self, spec: dict, real, builder):
        self.slots = {}  # (group, name) -> (is_int, first index, length or 0 for a scalar)
        counts = {False: 0, True: 0}
        for group, names in spec.items():
            for name, kind in names.items():
                base, n = kind if isinstance(kind, tuple) else (kind, 0)
                is_int = base == "int"
                self.slots[group, name] = (is_int, counts[is_int], n)
                counts[is_int] += max(n, 1)
        self.reals = ti.field(real)
        self.ints = ti.field(ti.i32)
        builder.dense(ti.i, max(counts[False], 1)).place(self.reals)
        builder.dense(ti.i, max(counts[True], 1)).place(self.ints)
        self._np_real = np.float64 if self.reals.dtype == ti.f64 else np.float32
        self.host = {False: np.zeros(max(counts[False], 1)), True: np.zeros(max(counts[True], 1),
                                                                            np.int64)}
        self.groups = {}
        for (group, name), (is_int, i, n) in self.slots.items():
            arr = self.ints if is_int else self.reals
            g = self.groups.setdefault(group, Group(group))
            setattr(g, name, _vector(arr, i, n) if n else _scalar(arr, i))

    def set(self, group: str, values: dict):
        """Stage ``values`` of ``group`` (names it declares) for the next :meth:`upload`."""
        for name, value in values.items():
            try:
                is_int, i, n = self.slots[group, name]
            except KeyError:
                raise KeyError(f"no run-time value {group}.{name} in this program") from None
            if n:
                value = np.asarray(value, dtype=np.float64 if not is_int else np.int64)
                if value.shape != (n,):
                    raise ValueError(f"{group}.{name} takes {n} values, got {value.shape}")
                self.host[is_int][i:i + n] = value
            else:
                self.host[is_int][i] = value

    def staged(self):
        """The staged values as the kernels' float and integer arrays (the program's load
        kernel copies them in)."""
        ints = self.host[True]
        if np.any(np.abs(ints) > np.iinfo(np.int32).max):
            raise OverflowError("a run-time integer exceeds the 32-bit range of the kernels")
        return self.host[False].astype(self._np_real), ints.astype(np.int32)

    def upload(self):
        """Copy the staged values into the fields (outside a program's load kernel)."""
        reals, ints = self.staged()
        self.reals.from_numpy(reals)
        self.ints.from_numpy(ints)
