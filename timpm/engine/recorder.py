"""Recording in the kernels: time, energies and tracked particles into a history buffer.

Python drains the buffer
(:class:`timpm.simulation.solver.Solver`: a dict of one array per drain and key) and reads the
drained records as time series (:func:`energy_series`, :func:`tracked_series`).
"""
import numpy as np
import taichi as ti

__all__ = ["Recorder", "series", "energy_series", "tracked_series", "NUMPY_DTYPES",
           "components", "entry_size"]

#: the NumPy type of a field's Taichi type
NUMPY_DTYPES = {ti.f64: np.float64, ti.f32: np.float32, ti.i32: np.int32, ti.i64: np.int64}


def components(fld):
    """(rows, columns) of a field's entries: (1, -1) a scalar, (n, 0) a vector."""
    if not isinstance(fld, ti.MatrixField):
        return (1, -1)
    return (fld.n, fld.m if fld.ndim == 2 else 0)


def entry_size(fld) -> int:
    """The numbers one entry of a scalar, vector or matrix field holds."""
    return fld.n * fld.m if isinstance(fld, ti.MatrixField) else 1


class Recorder:
    """See the module: the feature set, the particle fields, the history buffer (its
    fields ``history``, the count of records ``rec_count`` and the tracked particles'
    ids ``track_ids``: ``buffer``), the run fields, the laws (strain energies), the add of
    the mode and the run-time values."""

    def __init__(self, features, particles, history, buffer, run, laws, accumulate, values):
        self.f, self.dim = features, features.dim
        self.particles, self.history, self.buffer = particles, history, buffer
        self.run, self.laws, self.accumulate, self.values = run, laws, accumulate, values
        self.external_work = (features.traction is not None or features.body_force
                              or features.surface_force is not None or features.water_level)
        self.read_history = self._history_reader()

    @ti.func
    def record_step(self):
        slot = self.buffer.rec_count[None]
        # (f32 records: the time rounded)
        self.history.t[slot] = ti.cast(self.run.time[None], self.history.t.dtype)
        self.history.step[slot] = self.run.step_count[None]
        if ti.static(self.f.tracking):
            for j in range(self.values.n_tracked()):
                p = self.buffer.track_ids[j]
                self.history.x[slot, j] = self.particles.x[p]
                if ti.static(self.f.has_u):
                    self.history.u[slot, j] = self.particles.u[p]
                self.history.v[slot, j] = self.particles.v[p]
                self.history.stress[slot, j] = self.particles.sigma[p]
        if ti.static(self.f.energies):
            self.history.energy[slot] = ti.Vector.zero(float, 4)
            for p in range(self.values.n_particles()):
                # potential of gravity: -m g . u (1D), -m g . x (2D/3D, taken from its start
                # in energies())
                pot = 0.0
                for k in ti.static(range(self.dim)):
                    if ti.static(self.f.gravity[k]):
                        m, g = self.particles.m[p], self.values.gravity()[k]
                        if ti.static(self.f.has_u):
                            pot -= m * g * self.particles.u[p][k]
                        else:
                            x = self.particles.x[p][k]
                            if ti.static(self.f.periodic and k == 0):  # unwrapped
                                x += self.particles.laps[p] * self.values.elements()[0] \
                                    * self.values.h()
                            pot -= m * g * x
                e = ti.Vector([0.5 * self.particles.m[p] * self.particles.v[p].norm_sqr(),
                               self.laws.strain_energy(p), pot, 0.0])
                self.accumulate(self.history.energy[slot], e)
            if ti.static(self.external_work):
                self.history.energy[slot][3] = self.run.ext_work[None]
        self.buffer.rec_count[None] = slot + 1

    def _history_reader(self):
        """``read_history(n)``: the first n records of every history field, copied by one
        kernel into two float64 arrays (per record; per record and tracked particle) and
        returned in each field's dtype and ``to_numpy`` shape: one launch per drain (a
        ``to_numpy`` per field loads a kernel per field, ~9 ms each on the first read)."""
        fields = self.history.fields
        if not fields:
            return None
        layout = {1: [], 2: []}  # per record, per record and tracked particle
        cols = {1: 0, 2: 0}
        for name, fld in fields.items():
            rows, columns = components(fld)
            size = entry_size(fld)
            axes = len(fld.shape)
            layout[axes].append((name, fld, cols[axes], (rows, columns)))
            cols[axes] += size
        R = [(fld, col, shape) for _, fld, col, shape in layout[1]]
        T = [(fld, col, shape) for _, fld, col, shape in layout[2]]

        @ti.func
        def put(out: ti.template(), r, j, col, value):
            if ti.static(len(out.shape) == 2):
                out[r, col] = ti.cast(value, ti.f64)
            else:
                out[r, j, col] = ti.cast(value, ti.f64)

        @ti.func
        def copy(value, out: ti.template(), r, j, col: ti.template(), shape: ti.template()):
            if ti.static(shape[1] > 0):
                for a, b in ti.static(ti.ndrange(shape[0], shape[1])):
                    put(out, r, j, col + a * shape[1] + b, value[a, b])
            elif ti.static(shape[1] == 0):
                for a in ti.static(range(shape[0])):
                    put(out, r, j, col + a, value[a])
            else:
                put(out, r, j, col, value)

        @ti.kernel
        def read(n: ti.i32, records: ti.types.ndarray(dtype=ti.f64, ndim=2),
                 tracked: ti.types.ndarray(dtype=ti.f64, ndim=3)):
            # history -> host: the records, then per tracked particle
            for r in range(n):
                for k in ti.static(range(len(R))):
                    copy(R[k][0][r], records, r, 0, R[k][1], R[k][2])
                if ti.static(len(T) > 0):
                    for j in range(self.values.n_tracked()):
                        for k in ti.static(range(len(T))):
                            copy(T[k][0][r, j], tracked, r, j, T[k][1], T[k][2])

        def read_history(n: int, n_tracked: int) -> dict:
            records = np.zeros((max(n, 1), max(cols[1], 1)))
            per_particle = np.zeros((max(n, 1), max(n_tracked, 1), max(cols[2], 1)))
            read(n, records, per_particle)
            out = {}
            for axes, block in ((1, records), (2, per_particle)):
                for name, fld, col, (rows, columns) in layout[axes]:
                    # the shape of fld.to_numpy(): Taichi gives an n x 1 matrix as vectors
                    entry = () if columns < 0 else (rows,) if columns <= 1 else (rows, columns)
                    lead = (n,) if axes == 1 else (n, n_tracked)
                    a = block[tuple(slice(0, k) for k in lead)
                              + (slice(col, col + int(np.prod(entry))),)]
                    out[name] = a.reshape(lead + entry).astype(NUMPY_DTYPES[fld.dtype])
            return out

        return read_history


def series(history, key, empty=None):
    """The records of ``key`` as one array (``history`` holds one per drain)."""
    chunks = history.get(key)
    if not chunks:
        return np.zeros(0) if empty is None else empty
    return np.concatenate(chunks)


def energy_series(history, has_u) -> dict:
    """Recorded energies over time: kinetic, strain, gravity (potential), external work
    and total = kinetic + strain + gravity - external work (``has_u``: the 1D records,
    whose gravity is -m g . u)."""
    e = series(history, "energy")
    gravity = e[:, 2] if has_u else e[:, 2] - e[0, 2]  # 2D/3D: -m g . (x - x0)
    out = {"t": series(history, "t"), "kinetic": e[:, 0], "strain": e[:, 1],
           "gravity": gravity, "external_work": e[:, 3]}
    out["total"] = out["kinetic"] + out["strain"] + out["gravity"] - out["external_work"]
    return out


def tracked_series(history, dim) -> dict:
    """Recorded time series of the tracked particles: arrays of shape (records, tracked),
    one value per entry in 1D (Taichi returns the 1D vectors and 1x1 stresses as (..., 1))."""
    out = {"t": series(history, "t")}
    for key, empty in (("x", dim), ("u", dim), ("v", dim), ("stress", 1)):
        a = series(history, key, np.zeros((0, 0, empty)))
        out[key] = a[..., 0] if dim == 1 else a
    return out
