"""The state of one scene: what a solver uploads into its program and saves from it.

A :class:`State` knows which of a program's fields hold this scene's data and how much of
them (the live particles and nodes of a capacity), writes the scene's initial state,
and keeps the arrays in host memory while another scene of the same feature set holds
the program (``host``); it uploads the body force of each step, checks that a saved
state fits this scene (``fingerprint``, ``check_fits``) and counts the bytes its fields
take (``memory``).
"""
import numpy as np
import taichi as ti

from ..bases import stencils
from ..model.water import side_pressure_forces
from .recorder import entry_size
from ..schemes.rk4 import STAGE_TIMES

__all__ = ["State"]

#: run-time values that the saving and the restoring process may choose differently (the
#: private scatter's block of particles follows the thread count): not in the fingerprint
PROCESS_VALUES = ("scatter_block",)
#: the fingerprint's per-material entries and the word for one of their values
MATERIAL_ENTRIES = {"material_parameters": "parameter", "material_constants": "constant"}
_ABSENT = object()


class State:
    """The particle and grid data of one scene under its feature set and layout."""

    def __init__(self, features, layout, scene, track):
        self.features, self.layout = features, layout
        self.model = getattr(scene, "model", scene)
        self.track = list(track)
        self.host = None  # the arrays saved while another solver holds the program

    def load_into(self, prog):
        """Upload this solver's run-time values and state into ``prog``."""
        lay = self.layout
        values = dict(lay.values)
        values["node_count"] = int(np.prod(lay.nodes))
        values["nodes_per_thread"] = -(-values["node_count"] // self.features.n_copies)
        prog.params.set("p", {k: v for k, v in values.items() if ("p", k) in prog.params.slots})
        for k, consts in enumerate(lay.material_values):
            prog.params.set(f"m{k}", consts)
        fresh = self.host is None
        if fresh:
            self.host = self.initial(prog)
        prog.load(self.host, self.track)  # the staged values too
        self.host = None
        if fresh and self.model.initial_gradient is not None:
            prog.prestrain(np.ascontiguousarray(self.model.initial_gradient))

    def save_to_host(self, prog):
        """Keep this state in host memory (another solver takes the program)."""
        self.host = prog.save(self.layout.n_particles, int(np.prod(self.layout.nodes)))

    def snapshot(self, prog):
        """The state blocks of ``prog`` now (this state's program), as host arrays."""
        return prog.save(self.layout.n_particles, int(np.prod(self.layout.nodes)))

    def restore(self, prog, arrays):
        """Upload saved state blocks (:meth:`snapshot`, of the same layout) into ``prog``."""
        expected = prog.host_arrays(self.layout.n_particles, int(np.prod(self.layout.nodes)))
        for block, empty in expected.items():
            got = np.asarray(arrays.get(block))
            if got.shape != empty.shape or got.dtype != empty.dtype:
                raise ValueError(f"saved state block {block!r} has shape {got.shape} "
                                 f"({got.dtype}), this scene needs {empty.shape} ({empty.dtype})")
        self.host = {b: np.ascontiguousarray(arrays[b]) for b in expected}
        self.load_into(prog)

    def fingerprint(self, record_every) -> dict:
        """What a saved state must match to be restored into this scene, as JSON values
        (lists for tuples: it equals itself read back from a checkpoint's header).

        The feature set's physics (the mode, the scatter, the thread count and the arch
        may differ between the saving and the restoring process), the sizes, the grid, the
        time step, the precision, the tracked particles and ``record_every``; and the
        run-time physics: each material's parameters (E, nu, density, friction angle ...)
        and the constants its update reads, the run-time values (gravity, damping,
        pic_fraction, wall friction and velocities, the parameters of the loads and of the
        prescribed motion, the volume guard's range, the small-mass tolerance ...) and the
        fixed nodes with their velocities.  Functions cannot be compared: of a body force
        b(X, t) only whether one acts; the initial state (velocities, displacements) is the
        saved state's own."""
        f, lay, model = self.features, self.layout, self.model
        values = {k: v for k, v in lay.values.items() if k not in PROCESS_VALUES}
        values["pic_fraction"] = model.pic_fraction  # also where none applies: 0
        return _plain({
            "dim": f.dim, "basis": f.basis.name, "transfer": f.transfer,
            "consistent": f.consistent, "mls": f.mls,
            "materials": [[cls.__name__, repr(flags)] for cls, flags in f.materials],
            "walls": f.walls, "traction": _name(f.traction), "body_force": f.body_force,
            "surface_force": _name(f.surface_force), "prescribed": _name(f.prescribed),
            "particles": lay.n_particles, "nodes": lay.nodes, "h": float(lay.h),
            "dt": float(model.dt), "origin": [float(o) for o in lay.origin],
            "precision": f.precision, "tracked": self.track, "record_every": record_every,
            "material_parameters": [m.parameters() for m in lay.materials],
            "material_constants": lay.material_values, "values": values,
            "fixed_nodes": lay.fixed_nodes, "fixed_velocity": lay.fixed_velocity,
            **({} if f.water is None else {
                "water": f.water, "pore_water": [None if w is None else w.parameters()
                                                 for w in model.pore_water]}),
            **({} if not f.has_side_pressure else {
                "side_pressure": model.water.side_pressure,
                "side_pressure_time": _name(f.side_pressure)}),
            **({} if not f.planes else {"planes": f.planes})})

    def check_fits(self, prog, snapshot, record_every):
        """Refuse a snapshot (``Solver.snapshot``) whose fingerprint or state fields are
        not this scene's under ``prog``, naming the first difference and both values."""
        difference = _difference(self.fingerprint(record_every), snapshot["fingerprint"])
        if difference is not None:
            raise ValueError(f"the saved state does not fit this solver: {difference}")
        columns = {b: [tuple(e) for e in entries] for b, entries in snapshot["columns"].items()}
        if columns != {b: [tuple(e) for e in entries]
                       for b, entries in prog.state_layout().items()}:
            raise ValueError("the saved state holds other state fields than this solver "
                             "keeps (another material or feature set)")

    def memory(self, prog) -> dict:
        """Bytes per particle and per grid node of ``prog``'s state fields, the names of
        the particle fields, and the bytes per node of the private scatter's grid copies
        (``scatter_node_bytes``, 0 for the other strategies)."""
        copies = self.features.n_copies * sum(_field_bytes(f) for f in prog.copies.values())
        return {"particle_bytes": sum(_field_bytes(f) for f in prog.particle_fields.values()),
                "node_bytes": sum(_field_bytes(f) for f in prog.grid_fields.values()),
                "scatter_node_bytes": copies,
                "particle_fields": sorted(prog.particle_fields),
                "particles": self.layout.n_particles, "nodes": int(np.prod(self.layout.nodes))}

    def inertia(self, x):
        """D_p = sum_i phi_i (x_i - x_p)(x_i - x_p)^T of every particle at positions ``x``
        (n, dim): its diagonal, (n, dim)."""
        lay, basis = self.layout, self.features.basis
        out = np.empty_like(x)
        for k in range(self.features.dim):
            xi = (x[:, k] - lay.origin[k]) * lay.values["inv_h"]
            base, w, _ = stencils(basis, xi, lay.elements[k])
            r = (base[:, None] + np.arange(basis.support) - self.features.node_offset
                 - xi[:, None])
            out[:, k] = np.sum(w * (r * lay.h) ** 2, axis=1)
        return out

    def initial(self, prog):
        """The scene's initial state as the program's host arrays: positions, velocities,
        masses, volumes, the initial values the fields declare (F = I, J = 1), material
        indices, Dirichlet nodes, elements (crossings); the rest zero.  An initial stress
        sets sigma and the state each law takes from it (F, ezz) instead.  An initial displacement u0 places the particles
        at X + u0 (and sets the 1D u); its deformation is applied after the upload
        (``prestrain``)."""
        model, n, d = self.model, self.layout.n_particles, self.features.dim
        x = model.positions
        values = {}
        for name, fld in prog.particle_declarations.items():  # the declared initial values
            if fld.initial == "identity":
                values[name] = np.broadcast_to(np.eye(d), (n, d, d))
            elif fld.initial != 0.0:
                values[name] = np.full((n,) + fld.entries(d), float(fld.initial))
        values.update(v=model.velocity, m=model.mass_per_particle, vol=model.volume)
        if model.particle_values is not None:  # law fields given per particle (strength)
            values.update(model.particle_values)
        if model.initial_displacement is not None:
            x = x + model.initial_displacement
            values["u"] = model.initial_displacement
        if model.initial_stress is not None:  # the elastic state each law took from it
            values.update(sigma=model.initial_stress[:, :d, :d], work=model.initial_work,
                          **model.initial_state)
        pores = model.water_arrays
        if pores is not None:  # the pore water's state (engine/water.py)
            values.update(pores)
            if "pw" in pores:  # the grid sees sigma' - p_e I
                sigma = values.get("sigma", np.zeros((n, d, d)))
                values["sigma"] = sigma - pores["pw"][:, None, None] * np.eye(d)
            if self.features.coupled:
                values["w"] = model.velocity  # the water moves with the skeleton at first
        values.update(x=x, elem=self._element_of(x))
        if self.features.multi_material:
            values["mat"] = model.material_index
        if model.particle_force is not None:
            values["f_ext"] = model.particle_force
        if self.layout.fixed_nodes:
            fixed = np.zeros(self.layout.nodes, dtype=np.int32)
            velocity = np.zeros(tuple(self.layout.nodes) + (d,))
            for i, v in zip(self.layout.fixed_nodes, self.layout.fixed_velocity):
                fixed[i] = 1
                velocity[i] = v
            values["fixed"] = fixed
            values["fixed_v"] = velocity
        if self.features.has_side_pressure:  # the drained sides' pressures' forces
            values["gwb"] = side_pressure_forces(model)
        arrays = prog.host_arrays(n, int(np.prod(self.layout.nodes)))
        for block, entries in prog.state_layout().items():
            for name, col, comps in entries:
                if name in values:
                    rows = arrays[block].shape[0]
                    arrays[block][:, col:col + comps] = np.reshape(values[name], (rows, comps))
        return arrays

    def extent(self, prog, name):
        """The live part of field ``name``: its leading sizes for this scene."""
        fld = getattr(prog, name)
        if name in prog.particle_fields:
            return (self.layout.n_particles,)
        if any(fld is g for g in prog.grid_fields.values()):  # (also by a kernel's name)
            return tuple(self.layout.nodes)
        if name == "track_ids":
            return (self.layout.n_tracked,)
        return tuple(fld.shape) if fld.shape else None

    def read(self, prog, name):
        """The live part of field ``name`` as NumPy."""
        fld = getattr(prog, name)
        extent = self.extent(prog, name)
        if not fld.shape:
            value = fld[None]
            return np.asarray(value.to_numpy() if hasattr(value, "to_numpy") else value)
        return prog.read(fld, extent)

    def write(self, prog, name, values):
        """Set the live part of field ``name`` (the rest of the capacity is zero)."""
        fld = getattr(prog, name)
        if not fld.shape:
            fld[None] = values.tolist() if np.ndim(values) else values.item()
        else:
            prog.write(fld, values, self.extent(prog, name))
        if self.features.grid_window and any(fld is g for g in prog.grid_fields.values()):
            # a grid written from the host: the next step clears it whole (window.py)
            d = self.features.dim
            box = prog.window_box.to_numpy()
            box[:d], box[d:2 * d] = 0, self.layout.nodes
            prog.window_box.from_numpy(box)

    def window(self, prog):
        """The active window's box of the last step, U_n (lo, hi) per axis, or None
        without a window (engine/window.py)."""
        if not self.features.grid_window:
            return None
        d, box = self.features.dim, prog.window_box.to_numpy()
        return tuple(int(i) for i in box[2 * d:3 * d]), tuple(int(i) for i in box[3 * d:])

    def upload_body_force(self, prog, step):
        """The body force b(X, t) of every particle at the start of step ``step`` (t =
        step dt, the time the kernels keep; with the rk4 integrator also at t + dt/2 and
        t + dt, with the midpoint one at t + dt/2 only), evaluated in Python in one
        vectorised call per time, into ``prog``."""
        force = self.model.body_force
        if force.frame == "reference":
            X = self.model.positions
        else:
            X = self.read(prog, "x").reshape(self.layout.n_particles, self.features.dim)
        dt = self.model.dt
        if self.features.rk4:  # at the Runge-Kutta stage times, (n, stage, dim)
            values = np.stack([force(X, (step + c) * dt) for c in STAGE_TIMES], axis=1)
        elif self.features.midpoint:  # at mid-step
            values = force(X, (step + 0.5) * dt)
        else:
            values = force(X, step * dt)
        prog.set_body_force(np.ascontiguousarray(values))

    def _element_of(self, x):
        lay = self.layout
        xi = (x - np.asarray(lay.origin)) * lay.values["inv_h"]
        return np.clip(np.floor(xi), 0, np.asarray(lay.elements) - 1).astype(np.int32)


def _field_bytes(f) -> int:
    """Bytes one entry of a scalar, vector or matrix field holds."""
    return entry_size(f) * (8 if f.dtype in (ti.f64, ti.i64, ti.u64) else 4)


def _name(cls):
    """A class's name (a time function's, in the fingerprint), or None."""
    return None if cls is None else cls.__name__


def _plain(value):
    """``value`` in JSON's types: dicts with string keys, lists for tuples and arrays,
    Python numbers for NumPy's."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _difference(mine, theirs):
    """The first entry of fingerprint ``mine`` that the saved fingerprint ``theirs`` does
    not match, in words naming it and both values; None where they match."""
    for key, value in mine.items():
        other = theirs.get(key, _ABSENT)
        if key == "values" and isinstance(other, dict):
            pairs = [(value, other, "{}")]
        elif (key in MATERIAL_ENTRIES and isinstance(other, list) and len(other) == len(value)
              and all(isinstance(o, dict) for o in other)):
            pairs = [(a, b, f"material {k} {MATERIAL_ENTRIES[key]} {{}}")
                     for k, (a, b) in enumerate(zip(value, other))]
        else:
            pairs = [({key: value}, {} if other is _ABSENT else {key: other}, "{}")]
        for a, b, label in pairs:
            found = _first_difference(a, b, label)
            if found is not None:
                return found
    return None


def _first_difference(mine, theirs, label):
    """The first name whose value differs between the dicts ``mine`` and ``theirs`` (the
    saved one), or is in one only, as "its <label> is <saved value>, this solver's <value>"."""
    for name in [*mine, *(k for k in theirs if k not in mine)]:
        a, b = mine.get(name, _ABSENT), theirs.get(name, _ABSENT)
        if a is _ABSENT or b is _ABSENT or a != b:
            what = label.format(name)
            saved = f"it has no {what}" if b is _ABSENT else f"its {what} is {b!r}"
            this = "this solver has none" if a is _ABSENT else f"this solver's {a!r}"
            return f"{saved}, {this}"
    return None
