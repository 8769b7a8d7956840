"""The state of one scene: what a solver uploads into its program and saves from it.

A :class:`State` knows which of a program's fields hold this scene's data and how much of
them (the live particles and nodes of a capacity), writes the scene's initial state,
and keeps the arrays in host memory while another scene of the same feature set holds
the program (``host``).
"""
import numpy as np

__all__ = ["State"]


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

    def initial(self, prog):
        """The scene's initial state as the program's host arrays: positions, velocities,
        masses, volumes, F = I, J = 1, material indices, Dirichlet nodes, elements
        (crossings); the rest zero.  An initial displacement u0 places the particles at
        X + u0 (and sets the 1D u); its deformation is applied after the upload
        (``prestrain``)."""
        model, n, d = self.model, self.layout.n_particles, self.features.dim
        x = model.positions
        values = {"v": model.velocity, "m": model.mass_per_particle, "vol": model.volume,
                  "J": np.ones(n), "F": np.broadcast_to(np.eye(d), (n, d, d))}
        if model.initial_displacement is not None:
            x = x + model.initial_displacement
            values["u"] = model.initial_displacement
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
        if name in prog.grid_fields:
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

    def _element_of(self, x):
        lay = self.layout
        xi = (x - np.asarray(lay.origin)) * lay.values["inv_h"]
        return np.clip(np.floor(xi), 0, np.asarray(lay.elements) - 1).astype(np.int32)
