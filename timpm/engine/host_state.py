"""The state between host and kernels: every state field's place in the host arrays
(``state_layout``), the one launch that uploads a state (``load``: run-time values,
particle, node and scalar blocks, tracked particles, the grid and scratch fields cleared)
and the one that reads it back (``save``), and one field read or written alone
(``read``, ``write``).

The solver's states (:mod:`timpm.engine.state`), the checkpoints and the batches move
through it.
"""
import math

import numpy as np
import taichi as ti

from .drivers import c_order_index
from .expressions import at, expression
from .recorder import NUMPY_DTYPES, components, entry_size

__all__ = ["HostState"]


class HostState:
    """See the module: a program's fields by group (``particle``, ``grid``, ``copies``,
    ``scratch``, ``run``: dicts of name to field), its run-time values (``params``, the
    block, and ``values``, its getters), the flat-to-node index of the drivers
    (``node_of``) and, where it records, the count of records (``rec_count``)."""

    def __init__(self, fields, params, values, node_of, rec_count=None):
        self.particle_fields, self.grid_fields = fields["particle"], fields["grid"]
        self.copies, self.scratch_fields = fields["copies"], fields["scratch"]
        self.run_fields = fields["run"]
        self.params, self.values, self.node_of = params, values, node_of
        self.rec_count, self.recording = rec_count, rec_count is not None
        self._bind_transfers()

    @ti.func
    def _zero_entry(self, groups: ti.template(), i):
        """Entry i (flat, C order) of every field in ``groups`` (lists of fields of one
        shape) zeroed, where i is inside that shape."""
        for g in ti.static(range(len(groups))):
            shape = ti.static(groups[g][0].shape)
            if i < ti.static(math.prod(shape)):
                I = c_order_index(i, ti.static(shape), ti.static(len(shape)))
                for fld in ti.static(groups[g]):
                    fld[I] = ti.zero(fld[I])

    # ---- the state in and out, one launch each -----------------------------------------
    def state_layout(self):
        """Where each state field goes in the host arrays of :meth:`load` / :meth:`save`:
        ``{block: [(name, column, components), ...]}`` for the blocks ``"particles"`` and
        ``"particle_ints"`` (one row per particle), ``"nodes"`` and ``"node_ints"`` (one
        row per live node, C order) and ``"scalars"`` (one row)."""
        return self._state_layout

    def _bind_transfers(self):
        blocks = {"particles": [], "particle_ints": [], "nodes": [], "node_ints": [],
                  "scalars": []}
        cols = dict.fromkeys(blocks, 0)

        def add(block, name, fld):
            comps = entry_size(fld)
            blocks[block].append((name, cols[block], comps))
            cols[block] += comps

        for name, fld in self.particle_fields.items():
            add("particle_ints" if fld.dtype == ti.i32 else "particles", name, fld)
        for name in ("gv", "gu", "fixed", "fixed_v", "gwb"):
            if name in self.grid_fields:
                fld = self.grid_fields[name]
                add("node_ints" if fld.dtype == ti.i32 else "nodes", name, fld)
        for name, fld in self.run_fields.items():
            add("scalars", name, fld)
        if "body" in self.scratch_fields:
            add("scalars", "body", self.scratch_fields["body"])
        self._state_layout = {b: entries for b, entries in blocks.items()}
        self.state_columns = {b: max(cols[b], 1) for b in blocks}
        by_name = {**self.particle_fields, **self.grid_fields, **self.run_fields,
                   **self.scratch_fields}
        spec = {b: [(by_name[name], col, components(by_name[name]))
                    for name, col, _ in entries] for b, entries in blocks.items()}

        @expression
        def entry(fld, I):
            # fld[I], or fld[None] for a 0-D field (I unused)
            return at(fld, None if len(fld.shape) == 0 else I)

        @expression
        def host_value(fld, arr, row, col, shape):
            # a state field's entry from its host columns arr[row, col + component], in the
            # field's type
            def column(c):
                return ti.cast(at(arr, row, col + c), fld.dtype)
            if shape[1] > 0:
                return ti.Matrix([[column(i * shape[1] + j) for j in range(shape[1])]
                                  for i in range(shape[0])])
            if shape[1] == 0:
                return ti.Vector([column(i) for i in range(shape[0])])
            return column(0)

        @ti.func
        def get(fld: ti.template(), I, arr: ti.template(), row, col: ti.template(),
                shape: ti.template(), dtype: ti.template()):
            v = entry(fld, I)
            if ti.static(shape[1] > 0):
                for i, j in ti.static(ti.ndrange(shape[0], shape[1])):
                    arr[row, col + i * shape[1] + j] = ti.cast(v[i, j], dtype)
            elif ti.static(shape[1] == 0):
                for i in ti.static(range(shape[0])):
                    arr[row, col + i] = ti.cast(v[i], dtype)
            else:
                arr[row, col] = ti.cast(v, dtype)

        P, PI, N, NI, S = (spec[b] for b in blocks)
        f64, i32 = ti.types.ndarray(dtype=ti.f64, ndim=2), ti.types.ndarray(dtype=ti.i32, ndim=2)

        # fields whose every entry a step may read before writing it: cleared on load
        # (particle fields are loaded whole, history and team fields written before read)
        cleared = [f for f in [*self.grid_fields.values(), *self.copies.values(),
                               *self.scratch_fields.values()]
                   if f.shape and f is not self.scratch_fields.get("track_ids")
                   and f is not self.scratch_fields.get("rank_step")]
        by_shape = {}
        for f in cleared:
            by_shape.setdefault(tuple(f.shape), []).append(f)
        cleared = list(by_shape.values())
        params, track = self.params, self.scratch_fields.get("track_ids")
        tracking = track is not None
        i32_1d = ti.types.ndarray(dtype=ti.i32, ndim=1)

        n_reals, n_ints = params.reals.shape[0], params.ints.shape[0]
        # the loop lengths of load's first task and of both kernels' state loop: each
        # top-level loop is a task, and each task costs its JIT in every process (about
        # 7 ms from Taichi's offline cache, benchmarks/compile_floor.py)
        self._clear_rows = max([n_reals, n_ints] + [math.prod(g[0].shape) for g in cleared])

        @ti.kernel
        def load(particles: f64, particle_ints: i32, nodes: f64, node_ints: i32, scalars: f64,
                 reals: ti.types.ndarray(ndim=1), ints: i32_1d, track_ids: i32_1d,
                 clear_rows: ti.i32, rows: ti.i32):
            # task 1: the run-time values (the second task reads them), and the grid and
            # scratch fields cleared
            for i in range(clear_rows):
                if i < n_reals:
                    params.reals[i] = reals[i]
                if i < n_ints:
                    params.ints[i] = ints[i]
                self._zero_entry(cleared, i)
            # task 2: row i of the particle and node blocks, tracked particle i, the scalars
            for i in range(rows):
                if i < self.values.n_particles():
                    for k in ti.static(range(len(P))):
                        P[k][0][i] = host_value(P[k][0], particles, i, P[k][1], P[k][2])
                    for k in ti.static(range(len(PI))):
                        PI[k][0][i] = host_value(PI[k][0], particle_ints, i, PI[k][1],
                                                 PI[k][2])
                if i < self.values.node_count():
                    I = self.node_of(i)
                    for k in ti.static(range(len(N))):
                        N[k][0][I] = host_value(N[k][0], nodes, i, N[k][1], N[k][2])
                    for k in ti.static(range(len(NI))):
                        NI[k][0][I] = host_value(NI[k][0], node_ints, i, NI[k][1], NI[k][2])
                if ti.static(tracking):
                    if i < self.values.n_tracked():
                        track[i] = track_ids[i]
                if i == 0:  # the scalars: 0-D fields
                    for k in ti.static(range(len(S))):
                        S[k][0][None] = host_value(S[k][0], scalars, 0, S[k][1], S[k][2])
                    if ti.static(self.recording):
                        self.rec_count[None] = 0

        @ti.kernel
        def save(particles: f64, particle_ints: i32, nodes: f64, node_ints: i32, scalars: f64,
                 rows: ti.i32):
            # one task: row i of the particle and node blocks, the scalars
            for i in range(rows):
                if i < self.values.n_particles():
                    for k in ti.static(range(len(P))):
                        get(P[k][0], i, particles, i, P[k][1], P[k][2], ti.f64)
                    for k in ti.static(range(len(PI))):
                        get(PI[k][0], i, particle_ints, i, PI[k][1], PI[k][2], ti.i32)
                if i < self.values.node_count():
                    I = self.node_of(i)
                    for k in ti.static(range(len(N))):
                        get(N[k][0], I, nodes, i, N[k][1], N[k][2], ti.f64)
                    for k in ti.static(range(len(NI))):
                        get(NI[k][0], I, node_ints, i, NI[k][1], NI[k][2], ti.i32)
                if i == 0:
                    for k in ti.static(range(len(S))):
                        get(S[k][0], 0, scalars, 0, S[k][1], S[k][2], ti.f64)

        self._load, self._save = load, save

    def host_arrays(self, n_particles, n_nodes):
        """Zeroed host arrays of the state blocks for this many particles and live nodes."""
        rows = {"particles": n_particles, "particle_ints": n_particles, "nodes": n_nodes,
                "node_ints": n_nodes, "scalars": 1}
        return {b: np.zeros((max(rows[b], 1), self.state_columns[b]),
                            dtype=np.int32 if b.endswith("ints") else np.float64)
                for b in rows}

    def load(self, arrays, track_ids):
        """Upload the run-time values (staged in ``params``), the state blocks
        (:meth:`host_arrays`) and the tracked particles, the grid and scratch fields
        cleared: one launch."""
        reals, ints = self.params.staged()
        rows = max(len(arrays["particles"]), len(arrays["nodes"]), len(track_ids))
        self._load(arrays["particles"], arrays["particle_ints"], arrays["nodes"],
                   arrays["node_ints"], arrays["scalars"], reals, ints,
                   np.asarray(track_ids, dtype=np.int32).reshape(-1) if len(track_ids)
                   else np.zeros(1, np.int32), self._clear_rows, rows)

    def save(self, n_particles, n_nodes):
        """The state blocks of the live particles and nodes, from the fields: one launch."""
        arrays = self.host_arrays(n_particles, n_nodes)
        self._save(arrays["particles"], arrays["particle_ints"], arrays["nodes"],
                   arrays["node_ints"], arrays["scalars"],
                   max(len(arrays["particles"]), len(arrays["nodes"])))
        return arrays

    # ---- host transfers -------------------------------------------------------------------
    def read(self, fld, count=None):
        """Field values as NumPy, the first ``count`` entries along every axis given."""
        a = fld.to_numpy()
        if count is None:
            return a
        return a[tuple(slice(0, c) for c in count)]

    def write(self, fld, values, count):
        """Store ``values`` (``count`` entries along the leading axes) in the first entries
        of ``fld``, the rest zero."""
        shape = _numpy_shape(fld)
        full = np.zeros(shape, dtype=NUMPY_DTYPES[fld.dtype])
        count = tuple(count)
        full[tuple(slice(0, c) for c in count)] = np.asarray(values).reshape(
            count + shape[len(count):])
        fld.from_numpy(full)


def _numpy_shape(fld):
    """The shape of ``fld.to_numpy()``: Taichi gives an n x 1 matrix field as vectors."""
    if not isinstance(fld, ti.MatrixField):
        return tuple(fld.shape)
    return tuple(fld.shape) + ((fld.n,) if fld.m == 1 else (fld.n, fld.m))
