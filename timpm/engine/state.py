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
        self.features, self.layout, self.scene = features, layout, scene
        self.track = list(track)
        self.host = None  # the arrays saved while another solver holds the program

    def load_into(self, prog):
        """Upload this solver's run-time values and state into ``prog`` (just cleared)."""
        lay = self.layout
        values = dict(lay.values)
        values["node_count"] = int(np.prod(lay.nodes))
        values["nodes_per_thread"] = -(-values["node_count"] // self.features.n_copies)
        prog.params.set("p", {k: v for k, v in values.items() if ("p", k) in prog.params.slots})
        for k, consts in enumerate(lay.material_values):
            prog.params.set(f"m{k}", consts)
        prog.params.upload()
        if self.host is None:
            self.write_initial(prog)
        else:
            for name, values in self.host.items():
                self.write(prog, name, values)
            self.host = None

    def save_to_host(self, prog):
        """Keep this state in host memory (another solver takes the program)."""
        keep = {}
        for name in self.names(prog):
            keep[name] = self.read(prog, name)
        self.host = keep

    def names(self, prog):
        """The fields that hold this state between steps (the rest is cleared or rebuilt
        every step)."""
        names = list(prog.particle_fields) + list(prog.run_fields)
        names += [n for n in ("gv", "gu") if n in prog.grid_fields]
        if "body" in prog.scratch_fields:
            names.append("body")
        if "track_ids" in prog.scratch_fields:
            names.append("track_ids")
        if "fixed" in prog.grid_fields:
            names.append("fixed")
        return names

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

    def write_initial(self, prog):
        """The scene's initial state: positions, velocities, masses, volumes, F = I, J = 1,
        material indices, Dirichlet nodes, elements (crossings), tracked particles."""
        scene, n, d = self.scene, self.layout.n_particles, self.features.dim
        self.write(prog, "x", scene.positions.reshape(n, d))
        self.write(prog, "v", scene.velocity.reshape(n, d))
        self.write(prog, "m", scene.mass_per_particle)
        self.write(prog, "vol", scene.volume)
        if "J" in prog.particle_fields:
            self.write(prog, "J", np.ones(n))
        if "F" in prog.particle_fields:
            self.write(prog, "F", np.broadcast_to(np.eye(d), (n, d, d)))
        if "mat" in prog.particle_fields:
            self.write(prog, "mat", np.asarray(scene.material_index, dtype=np.int32))
        if "fixed" in prog.grid_fields:
            fixed = np.zeros(self.layout.nodes, dtype=np.int32)
            for i in self.layout.fixed_nodes:
                fixed[i] = 1
            self.write(prog, "fixed", fixed)
        if "elem" in prog.particle_fields:
            self.write(prog, "elem", self._element_of(scene.positions.reshape(n, d)))
        if self.layout.n_tracked:
            self.write(prog, "track_ids", np.asarray(self.track, dtype=np.int32))

    def _element_of(self, x):
        lay = self.layout
        xi = (x - np.asarray(lay.origin)) * lay.values["inv_h"]
        return np.clip(np.floor(xi), 0, np.asarray(lay.elements) - 1).astype(np.int32)
