"""Helpers Taichi calls while it builds a kernel (timpm/engine/expressions.py): the run-time
value getters and the stencil offsets give what the inlined ti.func gave, and Taichi warns
of no function from outside."""
import itertools
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
import taichi as ti

from timpm.bases import get_basis
from timpm.engine.expressions import expression
from timpm.engine.params import ParamBlock
from timpm.engine.stencil import Stencil
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
def test_the_stencil_rows_visit_every_node_in_c_order_with_its_weights(dim, basis):
    """Stencil.row, the one iterator of the phases over a particle's stencil: the offsets
    in C order (rows over every axis but the last, then the last), and at each the basis
    value and gradient of the tensor product node by node (node_weight: the same products
    in the same order, to the bit without fast math; the test session has it on, where
    the compiler may contract them differently in the two places)."""
    ensure_init()
    b = get_basis(basis)
    features = SimpleNamespace(dim=dim, basis=b, node_offset=0)
    s, support = Stencil(features, None), b.support
    n = support ** dim
    out = ti.Vector.field(dim, ti.i32, shape=n)
    phis = ti.field(ti.f64, shape=(2, n))
    grads = ti.Vector.field(dim, ti.f64, shape=(2, n))
    rng = np.random.default_rng(1)
    w_host, dw_host = rng.random((support, dim)), rng.standard_normal((support, dim))

    @ti.kernel
    def visit(w_in: ti.types.ndarray(), dw_in: ti.types.ndarray()):
        w = ti.Matrix.zero(ti.f64, support, dim)
        dw = ti.Matrix.zero(ti.f64, support, dim)
        for a, k in ti.static(ti.ndrange(support, dim)):
            w[a, k] = w_in[a, k]
            dw[a, k] = dw_in[a, k]
        for r in range(s.rows):
            for a, offset, phi, grad in ti.static(s.row(w, dw, r)):
                out[r * support + a] = offset
                phis[0, r * support + a] = phi
                grads[0, r * support + a] = grad
                phi1, grad1 = s.node_weight(w, dw, offset)
                phis[1, r * support + a] = phi1
                grads[1, r * support + a] = grad1

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        visit(w_host, dw_host)
    expected = np.array(list(itertools.product(range(support), repeat=dim)))
    assert np.array_equal(out.to_numpy().reshape(-1, dim), expected)
    phi, grad = phis.to_numpy(), grads.to_numpy()
    assert np.allclose(phi[0], phi[1], rtol=1e-15, atol=0)
    assert np.allclose(grad[0], grad[1], rtol=1e-15, atol=1e-300)
    # and they are the tensor products of the weights
    for i, o in enumerate(expected):
        assert phi[0, i] == pytest.approx(np.prod([w_host[o[k], k] for k in range(dim)]))
