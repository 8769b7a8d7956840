"""Helpers Taichi calls while it builds a kernel (timpm/engine/expressions.py): the run-time
value getters and the stencil offsets give what the inlined ti.func gave, and Taichi warns
of no function from outside."""
import itertools
import warnings

import numpy as np
import pytest
import taichi as ti

from timpm.bases import get_basis
from timpm.engine.expressions import expression
from timpm.engine.params import ParamBlock
from timpm.engine.stencil import StencilOps
from timpm.platform.runtime import ensure_init


def _compiled_without_warnings(kernel):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kernel()


def test_an_expression_helper_gives_what_the_same_ti_func_gives():
    ensure_init()
    out = ti.field(ti.f64, shape=(2, 4))

    @expression
    def helper(a, k):
        return a * k + 1.0

    @ti.func
    def inlined(a, k):
        return a * k + 1.0

    @ti.kernel
    def fill():
        for i in range(4):
            out[0, i] = helper(ti.cast(i, ti.f64), 0.5)
            out[1, i] = inlined(ti.cast(i, ti.f64), 0.5)

    _compiled_without_warnings(fill)
    assert out.to_numpy().tolist() == [[1.0, 1.5, 2.0, 2.5]] * 2


def test_the_run_time_value_getters_read_the_uploaded_values():
    ensure_init()
    fb = ti.FieldsBuilder()
    block = ParamBlock({"p": {"dt": "real", "origin": ("real", 2), "nodes": ("int", 3)}},
                       ti.f64, fb)
    fb.finalize()
    block.set("p", {"dt": 0.25, "origin": [-1.5, 2.0], "nodes": [3, 4, 7]})
    block.upload()
    g = block.groups["p"]
    out = ti.field(ti.f64, shape=6)

    @ti.kernel
    def read():
        out[0] = g.dt()
        origin = g.origin()
        out[1], out[2] = origin[0], origin[1]
        for k in ti.static(range(3)):
            out[3 + k] = g.nodes()[k]

    _compiled_without_warnings(read)
    assert out.to_numpy().tolist() == [0.25, -1.5, 2.0, 3.0, 4.0, 7.0]


@pytest.mark.parametrize("dim, basis", [(1, "bspline3"), (2, "uniform-bspline2"),
                                        (3, "uniform-bspline2"), (3, "linear")])
def test_the_stencil_offsets_run_through_the_rows_in_c_order(dim, basis):
    ensure_init()

    @ti.data_oriented
    class Stencil(StencilOps):
        def __init__(self):
            self.dim, self.basis = dim, get_basis(basis)
            self.stencil_rows = self.basis.support ** (dim - 1)

    s, support = Stencil(), get_basis(basis).support
    out = ti.Vector.field(dim, ti.i32, shape=support ** dim)

    @ti.kernel
    def offsets():
        for r in range(s.stencil_rows):
            for a in ti.static(range(support)):
                out[r * support + a] = s._offset_of(r, a)

    _compiled_without_warnings(offsets)
    expected = np.array(list(itertools.product(range(support), repeat=dim)))
    assert np.array_equal(out.to_numpy().reshape(-1, dim), expected)
