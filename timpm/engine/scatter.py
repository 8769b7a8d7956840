"""P2G scatter strategies: atomic adds, one thread's plain adds, private grid copies.

A scattering particle phase calls ``add(name, copy, node, value)`` (or ``deposit``, where
the 1D run sums may collect it) and :meth:`Scatter.run` runs the phase over the particles;
the strategy is a compile-time choice of the feature set:

- ``atomic``: parallel atomic adds into the grid (the GPU path);
- ``serial``: the scatter loop on one thread with plain adds (1D: a run of particles in
  one element summed in registers first, the *run sums*);
- ``private``: thread c adds into its own copy c of each scattered grid field, summed
  into the grid afterwards (``merged``, ``merge_copies``).

``accumulate(ref, value)`` is the add every other unit makes (plain in the fused serial
mode, atomic where threads may meet).
"""
import taichi as ti

__all__ = ["Scatter", "SUM_ROWS", "accumulate_in"]

#: rows of the 1D run sums (see ``FeatureSet.run_sums``)
SUM_ROWS = {"node_mass": 0, "node_force": 1, "node_momentum": 2}


def accumulate_in(mode):
    """``accumulate(ref, value)`` of the mode (the units below the scatter take it)."""
    return _Adds(mode).accumulate


class _Adds:
    def __init__(self, mode):
        self.mode = mode

    @ti.func
    def accumulate(self, ref: ti.template(), value):
        """ref += value.  In the fused serial mode every kernel of the solver is one task on
        one thread, so the add is plain, also where the task is a member of a parallel
        :class:`Batch` (whose tasks are parallel: Taichi would keep the atomic); else an
        atomic add (Taichi demotes it where the loop is serial or ref belongs to one
        iteration)."""
        if ti.static(self.mode == "serial"):
            ref = ref + value
        else:
            ref += value


class Scatter:
    """See the module: the feature set's strategy, the grid (its fields by kernel name),
    the private copies, the run-time values, the failure record (a particle of a failed
    step scatters nothing) and the particle capacity (a GPU's loops run to it)."""

    def __init__(self, features, grid, copies, values, failures, capacity, window=None):
        f = self.f = features
        self.dim, self.support, self.mode = f.dim, f.basis.support, f.mode
        self.grid, self.copies, self.values, self.failures = grid, copies, values, failures
        self.capacity, self.window = capacity, window
        self.windowed = window is not None  # (engine/window.py)
        self.accumulate = accumulate_in(f.mode)
        # the copies of scalar grid fields (node_mass, a scheme's masses): cleared as 0.0
        self.scalar_copies = frozenset(name for name, fld in copies.items()
                                       if not hasattr(fld, "n"))

    @ti.func
    def one_task(self, body: ti.template()):
        """Run ``body`` as one serial task in the fused serial mode, else as it is."""
        if ti.static(self.mode == "serial"):
            ti.loop_config(serialize=True)
            for _ in range(1):
                body()
        else:
            body()

    @ti.func
    def add(self, name: ti.template(), copy, node, value):
        """grid field ``name`` at ``node`` += value, by the scatter strategy: into the
        calling thread's private copy (plain adds) or the grid itself (atomic in a
        parallel loop, plain in a serial one)."""
        if ti.static(self.f.private_scatter):
            fld = ti.static(self.copies[name])
            at = self._copy_index(copy, node)
            fld[at] = fld[at] + value
        else:
            self.accumulate(ti.static(getattr(self.grid, name))[node], value)

    @ti.func
    def _copy_index(self, copy, node):
        """Index of ``node`` in private copy ``copy``."""
        at = ti.Vector.zero(ti.i32, self.dim + 1)
        at[0] = copy
        for k in ti.static(range(self.dim)):
            at[k + 1] = node[k]
        return at

    @ti.func
    def merged(self, name: ti.template(), I):
        """Grid quantity ``name`` at node I: with the private scatter the sum of the
        threads' copies (cleared for the next scatter), else the grid field itself."""
        total = ti.static(getattr(self.grid, name))[I]
        if ti.static(self.f.private_scatter):
            fld = ti.static(self.copies[name])
            for c in ti.static(range(self.f.n_copies)):
                at = self._copy_index(c, I)
                if ti.static(c == 0):
                    total = fld[at]
                else:
                    total += fld[at]
                if ti.static(name in self.scalar_copies):
                    fld[at] = 0.0
                else:
                    fld[at] = ti.Vector.zero(float, self.dim)
        return total

    @ti.func
    def merge_copies(self, names: ti.template()):
        # private scatter: sum the threads' grid copies into the grid, and clear them
        if ti.static(self.windowed):
            for I in ti.grouped(ti.ndrange(*self.window.ranges())):
                self._merge_node(names, I)
        else:
            for I in ti.grouped(ti.ndrange(*[self.values.nodes()[k] for k in range(self.dim)])):
                self._merge_node(names, I)

    @ti.func
    def _merge_node(self, names: ti.template(), I):
        for name in ti.static(names):
            grid = ti.static(getattr(self.grid, name))
            grid[I] = self.merged(name, I)  # a plain store: no other thread writes I

    @ti.func
    def run(self, phase: ti.template(), particles: ti.template(), grid: ti.template(),
            values: ti.template()):
        """A scheme's scattering particle phase (a ``schemes.Scatter``) for every particle,
        by the scatter strategy; the private copies merged after it where it says so."""
        if ti.static(self.f.private_scatter):
            # Taichi's CPU range-for gives thread c the iterations [c B, (c + 1) B) with
            # B = max(ceil(N / threads), 512): iteration p writes the copy of thread p // B
            B = self.values.scatter_block()
            for p in range(self.f.n_copies * B):
                if p < self.values.n_particles():
                    self.particle(phase, particles, grid, values, p, p // B)
        elif ti.static(self.f.run_sums):
            ti.loop_config(serialize=True)
            for _ in range(1):  # one task: the sums stay in registers
                rows = ti.static(phase.rows)
                first = -1  # first node of the run's stencil
                sums = ti.Matrix.zero(float, 3, self.support)
                for p in range(self.values.n_particles()):
                    base, inside, node_values = self.particle(phase, particles, grid, values,
                                                              p, 0)
                    if inside:
                        if base[0] != first:
                            self._add_sums(rows, first, sums)
                            first = base[0]
                            sums = ti.Matrix.zero(float, 3, self.support)
                        sums += node_values
                self._add_sums(rows, first, sums)
        elif ti.static(self.f.serial_scatter):
            ti.loop_config(serialize=True)  # plain adds instead of contended atomics
            for p in range(self.values.n_particles()):
                self.particle(phase, particles, grid, values, p, 0)
        elif ti.static(self.f.on_device):  # to the capacity: no serial task for the bound
            for p in range(self.capacity):
                if p < self.values.n_particles():
                    self.particle(phase, particles, grid, values, p, 0)
        else:
            for p in range(self.values.n_particles()):
                self.particle(phase, particles, grid, values, p, 0)
        if ti.static(self.f.private_scatter and len(phase.merge) > 0):
            self.merge_copies(phase.merge)

    @ti.func
    def particle(self, phase: ti.template(), particles: ti.template(), grid: ti.template(),
                 values: ti.template(), p, copy):
        """Particle p of a scattering phase: its stencil base, whether it scattered, and
        (run sums) its node values: rows m_i, F_i, P_i, one column per stencil node."""
        base = ti.Vector.zero(ti.i32, self.dim)
        inside = 0
        node_values = ti.Matrix.zero(float, 3, self.support)
        if not self.failures.halted(p):
            base, inside, node_values = phase.particle(particles, grid, values, p, copy)
        return base, inside, node_values

    @ti.func
    def _add_sums(self, rows: ti.template(), first, sums):
        """Add a run's node sums to the grid nodes first, first + 1, ... (none if first < 0)."""
        if first >= 0:
            for name in ti.static(rows):
                row = ti.static(SUM_ROWS[name])
                for a in ti.static(range(self.support)):
                    if ti.static(name == "node_mass"):
                        self.accumulate(self.grid.node_mass[first + a], sums[row, a])
                    else:
                        self.accumulate(ti.static(getattr(self.grid, name))[first + a][0],
                                        sums[row, a])

    @ti.func
    def deposit(self, name: ti.template(), copy, node, offset, value, node_values):
        """Scatter ``value`` to grid field ``name`` at ``node``: into the run sums' column
        ``offset`` (returned), or by the scatter strategy (``add``)."""
        if ti.static(self.f.run_sums):
            if ti.static(name == "node_mass"):
                node_values[SUM_ROWS[name], offset[0]] = value
            else:
                node_values[SUM_ROWS[name], offset[0]] = value[0]
        else:
            self.add(name, copy, node, value)
        return node_values

    @ti.func
    def reached(self, I):
        """Whether a particle scattered mass to node I (in any private copy)."""
        reached = False
        if ti.static(self.f.private_scatter):
            for c in ti.static(range(self.f.n_copies)):
                reached = reached or self.copies["node_mass"][self._copy_index(c, I)] != 0.0
        else:
            reached = self.grid.node_mass[I] != 0.0
        return reached
