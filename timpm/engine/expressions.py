"""Helpers that Taichi calls while it builds a kernel, not inlined ``ti.func``s.

A ``ti.func`` is inlined at each call with a local variable for each argument and for
its return value, their stores and their loads; Taichi's IR passes then remove most of
them again, at a cost that grows about as the square of the kernel's statements.  A
helper that only composes expressions from its arguments and compile-time values (no
loop or branch on a run-time value, no assignment into a Taichi variable) can instead
be a plain Python function that Taichi calls as it reads the kernel: it returns the
expression itself, and only the caller's own assignment makes a variable.  The step
of the 2D column-collapse scene: 7,560 statements, 5,820 with the run-time value getters
(:mod:`.params`), the stencil's offsets, row products and row nodes (:mod:`.stencil`) so
(docs/performance.md, "Time to the first step").
"""
import types

from taichi.lang import impl

__all__ = ["at", "expression", "variable"]


def expression(fn):
    """Mark ``fn`` as a helper that Taichi calls while it builds a kernel (see the module);
    marked as Taichi's own so that Taichi does not warn of a function from outside."""
    fn._is_taichi_function = True
    fn.func = types.SimpleNamespace(has_print=False)
    return fn


def at(value, *index):
    """``value[index]`` of a Taichi vector, matrix or field in a helper (what Taichi makes
    of the subscript in a kernel)."""
    return impl.subscript(None, value, *index)


def variable(value):
    """What ``x = value`` in a kernel makes of ``value``, for a helper to return: a local
    variable.  Taichi's transformer initialises the value twice (a Python-side vector or
    matrix becomes a matrix expression, that expression a variable); one initialisation
    leaves a vector an expression, rebuilt wherever it is read (three times the
    statements of a 3D stencil's rows, 538 -> 1,468 in a probe)."""
    return impl.expr_init(impl.expr_init(value))
