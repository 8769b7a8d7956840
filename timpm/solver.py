"""The MPM time step in Taichi: P2G, grid solve and G2P kernels.

One step is the study's Modified Lagrangian algorithm with Euler-Cromer time stepping
(section 2.2.4, Figure 2.7; 2.2.5):

1. P2G: mass matrix M (lumped or consistent) and forces F = F_grav + F_trac - F_int
2. grid: accelerations a = M^-1 F (Dirichlet nodes held at zero; local damping of A.4)
3. G2P: particle velocities v_p += dt sum_i phi_i a_i; P2G of the new momentum P
4. grid: nodal velocities v = M^-1 P
5. G2P: displacement and position u_p, x_p += sum_i phi_i v_i dt; strain increment
   d_eps = sum_i dphi_i v_i dt; stress, volume and density updates

In 2D/3D (a :class:`timpm.world.World`) the same phases also run the affine transfers
(APIC, MLS-MPM): P2G of mass and momentum with the affine part and dt times the force,
v = P / m with the wall conditions, G2P of v_p, C_p and the velocity gradient.

Every phase is a ``ti.func`` whose outermost loop runs over particles or nodes.  The same
phases compile into two kernels: ``_step`` (one launch per step, the loops parallel over
the CPU threads with atomic scatter) and ``_advance`` (many steps in one launch, the step
loop serialised, for small problems that would otherwise be dominated by launch cost).
The basis and the spatial dimension are compile-time parameters; fields a scene does not
need are not allocated and the code that would use them is not compiled.

Nothing is ever read or written out of bounds: a particle outside the grid, a NaN, an
inverted volume or a singular mass matrix sets an error record (code, step, particle or
node) and the run stops with a :class:`SimulationError` that names them.
"""

import sys
import time

import numpy as np
import taichi as ti

from .runtime import ensure_init, generation
from .materials import Hypoelastic1D
from .scene import Scene
from .world import World

__all__ = ["Solver", "SimulationError", "ERRORS", "SCATTERS"]

ERRORS = {
    1: "left the grid",
    2: "has a non-finite (NaN or infinite) state",
    3: "has a non-positive volume (the material inverted)",
    4: "the consistent mass matrix is singular",
    5: "energy grew without a source",
    6: "the threads of a team step did not meet at a barrier",
}

#: spins of a team barrier (an atomic read each, tens of ns) before the step gives up
TEAM_SPIN_LIMIT = 1 << 29


#: two-point Gauss-Legendre rule on [0, 1] (MLS projection: integration points)
GAUSS_POINTS = (0.5 - 0.5 / 3 ** 0.5, 0.5 + 0.5 / 3 ** 0.5)
GAUSS_WEIGHTS = (0.5, 0.5)


@ti.func
def _quadratic_spline(r):
    """Quadratic-spline MLS weight of 4.4, r = |x - x_p| / h (the continuous standard form)."""
    w = 0.0
    if r <= 0.5:
        w = 0.75 - r * r
    elif r <= 1.5:
        w = 0.5 * (1.5 - r) ** 2
    return w


@ti.func
def _cubic_spline(r):
    """Cubic-spline MLS weight of 4.4, r = |x - x_p| / (2 h)."""
    w = 0.0
    if r <= 0.5:
        w = 2.0 / 3.0 - 4.0 * r * r + 4.0 * r * r * r
    elif r <= 1.0:
        w = 4.0 / 3.0 * (1.0 - r) ** 3
    return w


@ti.func
def _mls_value(mom, b):
    """u_h(y) = p(y)^T A^-1 B u with p = [1, d]: the first coefficient of the 2x2 solve;
    Shepard's value sum w u / sum w where A is singular (fewer than two points around)."""
    det = mom[0] * mom[2] - mom[1] * mom[1]
    value = 0.0
    if det > 1e-10 * mom[0] * mom[0] and mom[0] > 0.0:
        value = (mom[2] * b[0] - mom[1] * b[1]) / det
    elif mom[0] > 0.0:
        value = b[0] / mom[0]
    return value


#: P2G scatter strategies: parallel atomic adds (the GPU path); the scatter loop on one
#: thread (plain adds); or one private grid copy per CPU thread, each filled with plain adds
#: by its share of the particles and summed into the grid afterwards.  "auto" picks
#: private on a multi-threaded CPU, serial on one thread and atomic on a GPU.
SCATTERS = ("auto", "atomic", "serial", "private")
#: rows of the 1D run sums (see ``Solver.run_sums``)
SUM_ROWS = {"gm": 0, "gf": 1, "gp": 2}


def _on_cpu() -> bool:
    from taichi.lang import impl

    return impl.current_cfg().arch in (ti.x64, ti.arm64)


def _cpu_threads() -> int:
    from taichi.lang import impl

    return max(1, int(impl.current_cfg().cpu_max_num_threads))


#: Taichi's CPU range-for hands each thread one contiguous block of at least this many
#: iterations (pass make_cpu_multithreading_loop); shorter loops run on one thread
_MIN_CPU_BLOCK = 512


def _static_cpu_blocks() -> bool:
    from taichi.lang import impl

    return bool(getattr(impl.current_cfg(), "make_cpu_multithreading_loop", False))


def auto_mode(n_particles: int, serial_threshold: int, cpu_threads: int) -> str:
    """The mode ``mode="auto"`` picks: fused serial steps up to ``serial_threshold``
    particles, and at any size on one CPU thread (``cpu_threads``: 0 off the CPU), where a
    parallel loop only hands its work to Taichi's pool and waits to be woken (0.1-0.4 ms
    per step on a 2-vCPU machine, at any particle count)."""
    return "serial" if n_particles <= serial_threshold or cpu_threads == 1 else "parallel"


class SimulationError(RuntimeError):
    """A run stopped because the state became invalid; the message names step and where."""

    def __init__(self, message, code=0, step=-1, particle=-1, node=-1):
        super().__init__(message)
        self.code, self.step, self.particle, self.node = code, step, particle, node


@ti.data_oriented
class Solver:
    """Particles and grid of one :class:`Scene` and the kernels that advance them.

    ``track`` lists particle indices whose state is recorded every ``record_every`` steps
    together with the energies; ``mode`` is ``"parallel"``, ``"serial"`` (fused steps, one
    thread, bit-reproducible), ``"team"`` (the affine transfer with the private scatter on
    two CPU threads or more: the passes of many steps in one parallel task, each thread a
    fixed block of particles and nodes, spin barriers between the passes; the parallel
    mode's results bit for bit) or ``"auto"`` (serial up to ``serial_threshold`` particles
    and at any size where Taichi runs one CPU thread, else team where it applies, else
    parallel).

    ``grid_displacement=True`` accumulates the nodal displacements u_i += v_i dt, so that
    the displacement field u_h(x) = sum_i phi_i(x) u_i can be drawn (study 5.2).

    With energies recorded, ``energy_guard`` stops an unstable run: kinetic + strain energy
    may not exceed ``energy_guard`` times the energy put in so far (initial kinetic and
    strain energy plus the magnitudes of the gravity and external work); ``None`` turns the
    check off.  The kernels hold up to ``history_chunk`` records between two reads from
    Python (default: about 4 MiB of them, 512 to 16384).
    """

    def __init__(self, scene, track=(), record_every: int = 1, energies: bool = True,
                 mode: str = "auto", serial_threshold: int = 4096,
                 history_chunk: int | None = None,
                 track_crossings: bool | None = None, energy_guard: float | None = 2.0,
                 grid_displacement: bool = False, small_mass: float = 1e-3,
                 scatter: str = "auto", check_every: int = 16):
        ensure_init()
        self._generation = generation()  # the Taichi start that holds the fields
        if not isinstance(scene, (Scene, World)):
            raise TypeError(f"Solver takes a timpm.Scene (1D) or a timpm.World (2D/3D), "
                            f"got {type(scene).__name__}")
        if mode not in ("auto", "parallel", "serial", "team"):
            raise ValueError(f"unknown mode {mode!r}: choose auto, parallel, serial or team")
        if record_every < 1:
            raise ValueError(f"record_every must be a positive integer, got {record_every!r}")
        self.scene = scene
        self.basis = scene.basis_class
        n = scene.n_particles
        track = [int(p) for p in track]
        for p in track:
            if not 0 <= p < n:
                raise ValueError(f"tracked particle {p} does not exist ({n} particles)")
        requested = mode
        if mode == "auto":
            mode = auto_mode(n, serial_threshold, _cpu_threads() if _on_cpu() else 0)
        self.mode = "parallel" if mode == "team" else mode  # a team runs the parallel kernels
        if scatter not in SCATTERS:
            raise ValueError(f"unknown scatter {scatter!r}: choose one of {', '.join(SCATTERS)}")
        private_ok = not (isinstance(scene, Scene) and
                          (scene.mass == "consistent" or scene.projection == "mls"))
        if scatter == "private" and not private_ok:
            raise ValueError("the private scatter needs a lumped mass without the MLS "
                             "projection; use scatter='serial' or 'atomic'")
        if scatter == "auto":
            # a float atomic add is a compare-and-swap loop on the CPU, ~5x a plain add:
            # plain adds into a grid copy per thread there, atomics on GPUs
            if not _on_cpu():
                scatter = "atomic"
            elif _cpu_threads() > 1 and private_ok and self.mode == "parallel":
                scatter = "private"
            else:
                scatter = "serial"
        self.scatter = scatter
        # in the fused serial mode every loop runs on one thread anyway
        self.serial_scatter = scatter == "serial" and self.mode == "parallel"
        # private: at least two copies, so that the path is the same on a one-core machine
        self.n_copies = max(2, _cpu_threads()) if scatter == "private" and self.mode == "parallel" else 1
        if self.n_copies > 1 and not _static_cpu_blocks():
            raise ValueError("the private scatter relies on Taichi's static split of CPU "
                             "range-for loops (make_cpu_multithreading_loop), which is off")
        self.scatter_block = max(_MIN_CPU_BLOCK, -(-n // self.n_copies))
        self.private_scatter = self.n_copies > 1
        self.record_every = int(record_every)
        if int(check_every) < 1:
            raise ValueError(f"check_every must be a positive integer, got {check_every!r}")
        self.check_every = int(check_every)
        if history_chunk is not None and int(history_chunk) < 1:
            raise ValueError(f"history_chunk must be a positive integer, got {history_chunk!r}")
        self.history_chunk = None if history_chunk is None else int(history_chunk)
        self.n_particles = n
        self.h = scene.grid.h if isinstance(scene, Scene) else scene.h
        self.inv_h = 1.0 / self.h
        self.dt = scene.dt
        if isinstance(scene, Scene):
            self._configure_1d(scene)
        else:
            self._configure_world(scene)
        self.n_elements = self.grid_elements[0]
        self.n_nodes = self.grid_nodes[0]
        self.node_offset = self.basis.offset() if hasattr(self.basis, "offset") else 0
        if grid_displacement and self.dim != 1:
            raise ValueError("grid_displacement is available for 1D scenes only")
        # compile-time feature set, frozen here: state fields of the materials, affine
        # transfer, per-particle material index where a scene mixes materials
        self.needs = frozenset().union(*(m.needs for m in self.materials))
        # the affine transfers: APIC, and MLS-MPM (Hu et al. 2018), which also takes the
        # force and the velocity gradient from the affine moments: grad phi_i ~ D^-1 phi_i dx
        self.apic = self.transfer in ("apic", "mls-mpm")
        self.mls_mpm = self.transfer == "mls-mpm"
        # APIC with the linear basis takes the strain increment from the remapped velocity
        # P'_i / m_i, P'_i = sum_p m_p phi_i v_p (the study's MUSL remap, 2.2.4): the grid
        # velocity of a node a particle barely touches ~ 1 / phi and grad phi does not
        # vanish with phi, so sum_i v_i grad phi_i^T is unbounded there (v_p and C_p are not)
        self.strain_remap = self.transfer == "apic" and self.basis.support == 2
        if self.mls_mpm:
            self.D_inv = 1.0 / (self.basis.inertia * self.h ** 2)
        self.multi_material = len(self.materials) > 1
        # team: the passes of many steps in one parallel task, each thread a fixed block of
        # particles (its own grid copy) and of nodes, the passes separated by spin barriers:
        # Taichi's pool is woken once per launch, not three times per step
        team_ok = (self.private_scatter and self.apic and not self.strain_remap
                   and _cpu_threads() >= self.n_copies)  # a thread for every block
        if requested == "team" and not team_ok:
            raise ValueError("mode='team' needs the private scatter with a thread per grid "
                             "copy (two CPU threads or more) and the affine transfer (APIC "
                             "with a B-spline basis, or MLS-MPM)")
        self.team = team_ok and requested in ("team", "auto")
        # 1D on one thread (MUSL, lumped, standard projection): neighbouring particles share
        # their element, so a run of them sums its node values in registers and adds them to
        # the grid once (a store-to-load chain through the grid per particle otherwise)
        self.run_sums = (self.dim == 1 and not self.apic and not self.consistent and not self.mls
                         and (self.mode == "serial" or self.serial_scatter))
        # rows of the run sums: the grid fields each scattering phase adds to
        self.scatter_rows = {"p2g": ("gm", "gf") + (("gp",) if self.damping > 0.0 else ()),
                             "g2p-velocity": ("gp",)}
        # V_p = det(F) V0, unless every material's stress acts on the initial volume
        self.update_volume = not all(m.initial_volume for m in self.materials)
        self.has_walls = self.walls is not None
        self.track_crossings = (self.dim == 1) if track_crossings is None else bool(track_crossings)
        self.grid_displacement = bool(grid_displacement)
        self.n_tracked = len(track)
        self.recording = energies or self.n_tracked > 0
        self.record_energies = bool(energies)
        self.energy_guard = energy_guard if energies else None
        self._energy_input = 0.0
        self.bandwidth = self.basis.support - 1
        mass_scale = float(np.mean(scene.mass_per_particle))
        # nodes with less mass than this are empty; the consistent mass drops nodes that a
        # particle barely touches (their rows make M ill-conditioned: the small-mass problem)
        self.mass_tol = (small_mass if self.consistent else 1e-14) * mass_scale
        self.pivot_tol = 1e-14 * mass_scale
        self._allocate(scene, track)
        self._bind_launchers()
        self.history = {"t": [], "step": []}
        self.compile_seconds = 0.0
        self.run_seconds = 0.0
        self._compiled = False
        self._timed_steps = 0
        self._first_step = 0.0

    def _configure_1d(self, scene: Scene):
        """The study's 1D scene: Dirichlet nodes, tractions, consistent mass, MLS."""
        self.dim = 1
        self.grid_elements = (scene.grid.n_elements,)
        self.grid_nodes = (self.basis.n_nodes(scene.grid.n_elements),)
        self.origin = (scene.grid.origin,)
        self.gravity = (float(scene.gravity),)
        self.materials = [Hypoelastic1D(scene.material.E, scene.material.stress_update == "study")]
        self.transfer = "musl"
        self.walls = None
        self.consistent = scene.mass == "consistent"
        self.mls = scene.projection == "mls"
        self.damping = float(scene.damping)
        self.has_traction = scene.traction is not None
        self.traction_particle = scene.traction.particle if self.has_traction else -1
        self.traction_amplitude = float(scene.traction.amplitude) if self.has_traction else 0.0
        self.traction_fn = scene.traction.time_function if self.has_traction else None
        self.has_u = True
        self.fixed_nodes = [(i,) for i in scene.fixed_nodes]

    def _configure_world(self, world: World):
        """A 2D/3D world: materials per body, walls on every side of the domain."""
        self.dim = world.dim
        self.grid_elements = world.grid_elements
        self.grid_nodes = tuple(self.basis.n_nodes(n) for n in self.grid_elements)
        self.origin = world.origin
        self.gravity = tuple(float(g) for g in world.gravity)
        self.materials = list(world.materials)
        self.transfer = world.transfer
        self.pad = world.padding
        self.domain_cells = tuple(n - 2 * world.padding for n in world.grid_elements)
        # per side: (kind, friction coefficient), sides in the order of world.SIDES
        self.walls = tuple((w.kind, w.mu) for w in world.walls)
        self.consistent = False
        self.mls = False
        self.damping = float(world.damping)
        self.has_traction = False
        self.has_u = False
        self.fixed_nodes = []

    # ---- fields ------------------------------------------------------------------------
    def _allocate(self, scene, track):
        d, n = self.dim, self.n_particles
        fb = ti.FieldsBuilder()
        real = float  # Taichi's default_fp: timpm.init(precision=...)
        self.x = ti.Vector.field(d, real)
        self.v = ti.Vector.field(d, real)
        self.m = ti.field(real)
        self.vol = ti.field(real)
        self.sigma = ti.Matrix.field(d, d, real)
        particle_fields = [self.x, self.v, self.m, self.vol, self.sigma]
        # state only where a feature of the scene needs it
        if self.has_u:
            self.u = ti.Vector.field(d, real)  # displacement, for the 1D analytic solutions
            particle_fields.append(self.u)
        if "eps" in self.needs:
            self.eps = ti.Matrix.field(d, d, real)  # accumulated strain (1D law)
            particle_fields.append(self.eps)
        if "F" in self.needs:
            self.F = ti.Matrix.field(d, d, real)  # (elastic) deformation gradient
            particle_fields.append(self.F)
        if "J" in self.needs:
            self.J = ti.field(real)  # volume ratio advanced by its linearised rate (JFluid)
            particle_fields.append(self.J)
        if "plastic" in self.needs:
            self.plastic = ti.field(real)  # accumulated plastic strain
            particle_fields.append(self.plastic)
        if self.apic:
            # affine velocity C_p of the APIC transfers (B_p = C_p D_p for the linear basis)
            self.C = ti.Matrix.field(d, d, real)
            particle_fields.append(self.C)
        if self.multi_material:
            self.mat = ti.field(ti.i32)
            particle_fields.append(self.mat)
        if self.record_energies:
            self.work = ti.field(real)  # strain energy, integrated along the path
            particle_fields.append(self.work)
        if self.track_crossings:
            self.elem = ti.Vector.field(d, ti.i32)
            particle_fields.append(self.elem)
        fb.dense(ti.i, n).place(*particle_fields)
        self._particle_fields = particle_fields
        # grid: mass, momentum then velocity, force then acceleration (the affine transfer
        # folds the force into the momentum), Dirichlet mask (1D)
        self.gm = ti.field(real)
        self.gp = ti.Vector.field(d, real)
        grid_fields = [self.gm, self.gp]
        if not self.apic:
            self.gf = ti.Vector.field(d, real)
            grid_fields.append(self.gf)
        else:
            self.gv = ti.Vector.field(d, real)  # velocity of the last grid update
            grid_fields.append(self.gv)
        if self.fixed_nodes:
            self.fixed = ti.field(ti.i32)
            grid_fields.append(self.fixed)
        fb.dense(ti.axes(*range(d)), self.grid_nodes).place(*grid_fields)
        self._grid_fields = grid_fields
        # private scatter: thread k fills copy k of each scattered grid field (a leading
        # copy axis: no branch on the thread per add), summed into the grid afterwards
        self.copies = {}
        if self.private_scatter:
            scattered = ["gm", "gp"] + ([] if self.apic else ["gf"])
            for name in scattered:
                self.copies[name] = ti.field(real) if name == "gm" else ti.Vector.field(d, real)
            fb.dense(ti.axes(*range(d + 1)), (self.n_copies, *self.grid_nodes)).place(
                *self.copies.values())
        if self.grid_displacement:
            self.gu = ti.Vector.field(d, real)
            fb.dense(ti.axes(*range(d)), self.grid_nodes).place(self.gu)
        nn = self.grid_nodes[0]
        if self.consistent:
            if d != 1:
                raise ValueError("the consistent mass matrix is implemented for 1D scenes only")
            self.band = ti.field(real)  # M[i, i + k - b] stored at band[i, k]
            self.inactive = ti.field(ti.i32)  # fixed or untouched rows of M
            fb.dense(ti.ij, (nn, 2 * self.bandwidth + 1)).place(self.band)
            fb.dense(ti.i, nn).place(self.inactive)
        if self.mls:
            ne, ng = self.n_elements, len(GAUSS_POINTS)
            self.g_mom = ti.Vector.field(3, real)  # MLS moments sum w [1, d, d^2] at Gauss points
            self.g_rho = ti.Vector.field(2, real)  # sum w rho_p [1, d]
            self.g_sig = ti.Vector.field(2, real)  # sum w sigma_p [1, d]
            fb.dense(ti.ij, (ne, ng)).place(self.g_mom, self.g_rho, self.g_sig)
            self.body = ti.Vector.field(2, real)  # extent of the body: union of x_p -+ V_p / 2
            fb.place(self.body)
            self.n_mom = ti.Vector.field(3, real)  # the same at the nodes, for the velocity
            self.n_vel = ti.Vector.field(2, real)
            fb.dense(ti.i, nn).place(self.n_mom, self.n_vel)
        # run state and the first error
        self.step_count = ti.field(ti.i64)
        self.time = ti.field(ti.f64)
        self.crossings = ti.field(ti.i64)
        self.err = ti.field(ti.i32)
        self.err_count = ti.field(ti.i32)
        self.err_step = ti.field(ti.i64)
        self.err_where = ti.field(ti.i32)
        self.neg_pivots = ti.field(ti.i64)
        fb.place(self.step_count, self.time, self.crossings, self.err, self.err_count, self.err_step,
                 self.err_where, self.neg_pivots)
        if self.team:
            self.team_arrived = ti.field(ti.i32)  # arrivals at the barriers of a launch
            self.team_abort = ti.field(ti.i32)
            self.rank_step = ti.field(ti.i64)  # the step each thread of the team is in
            fb.place(self.team_arrived, self.team_abort)
            fb.dense(ti.i, self.n_copies).place(self.rank_step)
        if self.recording:
            if self.history_chunk is None:
                # records the kernels hold between two reads from Python: about 4 MiB
                per_tracked = 8 * (2 * d + d * d + (d if self.has_u else 0))
                record = 16 + 32 * self.record_energies + self.n_tracked * per_tracked
                self.history_chunk = min(16384, max(512, (4 << 20) // record))
            cap = self.history_chunk
            self.rec_count = ti.field(ti.i32)
            self.h_t = ti.field(real)
            self.h_step = ti.field(ti.i64)
            fb.place(self.rec_count)
            fb.dense(ti.i, cap).place(self.h_t, self.h_step)
            if self.record_energies:
                self.h_energy = ti.Vector.field(4, real)  # kinetic, strain, gravity, external
                fb.dense(ti.i, cap).place(self.h_energy)
            if self.n_tracked:
                self.track_ids = ti.field(ti.i32)
                fb.dense(ti.i, self.n_tracked).place(self.track_ids)
                self.h_x = ti.Vector.field(d, real)
                self.h_v = ti.Vector.field(d, real)
                self.h_s = ti.Matrix.field(d, d, real)
                fb.dense(ti.ij, (cap, self.n_tracked)).place(self.h_x, self.h_v, self.h_s)
                if self.has_u:
                    self.h_u = ti.Vector.field(d, real)
                    fb.dense(ti.ij, (cap, self.n_tracked)).place(self.h_u)
        if self.record_energies and self.has_traction:
            self.ext_work = ti.field(real)
            fb.place(self.ext_work)
        self._tree = fb.finalize()

        x = scene.positions.reshape(n, d)
        real_np = np.float64 if self.x.dtype == ti.f64 else np.float32
        self.x.from_numpy(x.astype(real_np))
        self.v.from_numpy(scene.velocity.reshape(n, d).astype(real_np))
        self.m.from_numpy(scene.mass_per_particle.astype(real_np))
        self.vol.from_numpy(scene.volume.astype(real_np))
        if self.has_u:
            self.u.from_numpy(np.zeros((n, d), dtype=real_np))
        if "J" in self.needs:
            self.J.fill(1.0)
        if "F" in self.needs:
            self.F.from_numpy(np.broadcast_to(np.eye(d, dtype=real_np), (n, d, d)).copy())
        if self.multi_material:
            self.mat.from_numpy(np.asarray(scene.material_index, dtype=np.int32))
        if self.fixed_nodes:
            fixed = np.zeros(self.grid_nodes, dtype=np.int32)
            for i in self.fixed_nodes:
                fixed[i] = 1
            self.fixed.from_numpy(fixed)
        if self.track_crossings:
            self.elem.from_numpy(self._element_of(x))
        if self.n_tracked:
            self.track_ids.from_numpy(np.asarray(track, dtype=np.int32))

    # ---- reset ---------------------------------------------------------------------------
    def reset(self):
        """Back to the scene's initial state, keeping the compiled kernels: a second run
        of the same scene (a study repeated, a parameter sweep over loads read at run time)
        costs no compilation.  The first call allocates a copy of the initial positions,
        velocities and volumes."""
        self._prepare_reset()
        self._reset_kernel()
        self._reset_host()
        return self

    def _prepare_reset(self):
        """Allocate and fill the copy of the initial state (once)."""
        self._require_fields()
        if getattr(self, "_initial_tree", None) is None:
            fb = ti.FieldsBuilder()
            d, real = self.dim, self.x.dtype
            self.x_init, self.v_init = ti.Vector.field(d, real), ti.Vector.field(d, real)
            self.vol_init = ti.field(real)
            fb.dense(ti.i, self.n_particles).place(self.x_init, self.v_init, self.vol_init)
            self._initial_tree = fb.finalize()
            real_np = np.float64 if real == ti.f64 else np.float32
            n = self.n_particles
            self.x_init.from_numpy(self.scene.positions.reshape(n, d).astype(real_np))
            self.v_init.from_numpy(self.scene.velocity.reshape(n, d).astype(real_np))
            self.vol_init.from_numpy(self.scene.volume.astype(real_np))

    def _reset_host(self):
        self.history = {"t": [], "step": []}
        self.run_seconds = 0.0
        self.compile_seconds = 0.0
        self._energy_input = 0.0

    def _state_fields(self):
        """Fields a run changes that start at zero (all but x, v, V and the fields the
        reset sets otherwise)."""
        keep = {id(f) for f in (self.x, self.v, self.m, self.vol)}
        for name in ("F", "J", "mat", "elem", "fixed", "track_ids"):
            if hasattr(self, name):
                keep.add(id(getattr(self, name)))
        fields = [f for f in self._particle_fields + self._grid_fields if id(f) not in keep]
        fields += list(self.copies.values())
        for name in ("gu", "band", "inactive", "g_mom", "g_rho", "g_sig", "body", "n_mom",
                     "n_vel", "step_count", "time", "crossings", "err", "err_count",
                     "err_step", "err_where", "neg_pivots", "rec_count", "ext_work"):
            if hasattr(self, name):
                fields.append(getattr(self, name))
        return fields

    @ti.func
    def _reset_state(self):
        for fld in ti.static(self._state_fields()):
            if ti.static(len(fld.shape) == 0):
                fld[None] = ti.zero(fld[None])
            else:
                for I in ti.grouped(ti.ndrange(*fld.shape)):
                    fld[I] = ti.zero(fld[I])
        for p in range(self.n_particles):
            self.x[p] = self.x_init[p]
            self.v[p] = self.v_init[p]
            self.vol[p] = self.vol_init[p]
            if ti.static("F" in self.needs):
                self.F[p] = ti.Matrix.identity(float, self.dim)
            if ti.static("J" in self.needs):
                self.J[p] = 1.0
            if ti.static(self.track_crossings):
                xi = ti.Vector.zero(float, self.dim)
                for k in ti.static(range(self.dim)):
                    xi[k] = (self.x[p][k] - self.origin[k]) * self.inv_h
                self.elem[p] = self._element(xi)

    @ti.kernel
    def _reset_kernel(self):
        self._one_task(self._reset_state)

    @ti.func
    def _element(self, xi):
        """Element of a point at ``xi`` (element units), clamped to the grid (as
        :meth:`_element_of`)."""
        e = ti.Vector.zero(ti.i32, self.dim)
        for k in ti.static(range(self.dim)):
            e[k] = ti.min(ti.max(ti.floor(xi[k], ti.i32), 0), self.grid_elements[k] - 1)
        return e

    def _element_of(self, x):
        xi = (x - np.asarray(self.origin)) * self.inv_h
        return np.clip(np.floor(xi), 0, np.asarray(self.grid_elements) - 1).astype(np.int32)

    def memory(self) -> dict:
        """Bytes per particle and per grid node of the state fields this scene allocated,
        the names of those fields, and the bytes per node of the private scatter's grid
        copies (``scatter_node_bytes``, 0 for the other strategies)."""
        names = [k for k, v in vars(self).items() if any(v is f for f in self._particle_fields)]
        copies = self.n_copies * sum(_field_bytes(f) for f in self.copies.values())
        return {"particle_bytes": sum(_field_bytes(f) for f in self._particle_fields),
                "node_bytes": sum(_field_bytes(f) for f in self._grid_fields),
                "scatter_node_bytes": copies,
                "particle_fields": sorted(names),
                "particles": self.n_particles, "nodes": int(np.prod(self.grid_nodes))}

    def release(self):
        """Free the fields of this solver (it cannot be used afterwards)."""
        for name in ("_tree", "_initial_tree"):
            if getattr(self, name, None) is not None:
                if self._generation == generation():  # else Taichi freed them at its restart
                    getattr(self, name).destroy()
                setattr(self, name, None)

    def _require_fields(self):
        """A clear error, not a launch on freed memory, for a solver without its fields."""
        if getattr(self, "_tree", None) is None:
            raise RuntimeError("this solver was released")
        if self._generation != generation():
            raise RuntimeError("Taichi was restarted (timpm.init with other settings) after "
                               "this solver was built, which freed its fields: build a new "
                               "Solver")

    # ---- stencil -----------------------------------------------------------------------
    @ti.func
    def _stencil(self, p):
        """Node base, weights and gradients of particle p, its coordinate in element units,
        and whether p is on the grid."""
        xi = ti.Vector.zero(float, self.dim)
        base = ti.Vector.zero(ti.i32, self.dim)
        w = ti.Matrix.zero(float, self.basis.support, self.dim)
        dw = ti.Matrix.zero(float, self.basis.support, self.dim)
        inside = 1
        for k in ti.static(range(self.dim)):
            xi[k] = (self.x[p][k] - self.origin[k]) * self.inv_h
            # NaN fails both comparisons, so it is caught here too
            if not (xi[k] >= 0.0 and xi[k] <= self.grid_elements[k]):
                inside = 0
            b, wk, dwk = self.basis.stencil(xi[k], self.grid_elements[k])
            base[k] = b
            if b < 0 or b + self.basis.support > self.grid_nodes[k]:
                inside = 0
            for a in ti.static(range(self.basis.support)):
                w[a, k] = wk[a]
                dw[a, k] = dwk[a] * self.inv_h
        return base, w, dw, xi, inside

    @ti.func
    def _weight(self, w, dw, offset):
        """Tensor-product value and gradient of the basis function at stencil ``offset``."""
        phi = 1.0
        grad = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            phi *= w[offset[k], k]
        for j in ti.static(range(self.dim)):
            g = 1.0
            for k in ti.static(range(self.dim)):
                if ti.static(j == k):
                    g *= dw[offset[k], k]
                else:
                    g *= w[offset[k], k]
            grad[j] = g
        return phi, grad

    @ti.func
    def _from_first_node(self, xi, base):
        """x_p - x of the stencil's first node, so that x_i - x_p = h o - this for the node
        at stencil offset o (the factored affine terms of P2G and G2P)."""
        return (xi - ti.cast(base, float) + self.node_offset) * self.h

    @ti.func
    def _times_offset(self, A, offset: ti.template()):
        """A o for a stencil offset o known at compile time: column adds, no products."""
        out = ti.Vector.zero(float, self.dim)
        for k in ti.static(range(self.dim)):
            if ti.static(offset[k] > 0):
                for j in ti.static(range(self.dim)):
                    out[j] += A[j, k] if ti.static(offset[k] == 1) else offset[k] * A[j, k]
        return out

    @ti.func
    def _outer_offset(self, u, offset: ti.template()):
        """u o^T for a stencil offset o known at compile time."""
        out = ti.Matrix.zero(float, self.dim, self.dim)
        for k in ti.static(range(self.dim)):
            if ti.static(offset[k] > 0):
                for j in ti.static(range(self.dim)):
                    out[j, k] = u[j] if ti.static(offset[k] == 1) else offset[k] * u[j]
        return out

    @ti.func
    def _fail(self, code, where):
        """Record the first error of the run: its code, step and particle or node."""
        first = False
        if ti.static(self.mode == "serial"):
            first = self.err_count[None] == 0
            self.err_count[None] = self.err_count[None] + 1
        else:
            first = ti.atomic_add(self.err_count[None], 1) == 0
        if first:
            self.err[None] = code
            if ti.static(self.team):  # where: a particle of the thread's block
                self.err_step[None] = self.rank_step[where // self.scatter_block]
            else:
                self.err_step[None] = self.step_count[None]
            self.err_where[None] = where

    @ti.func
    def _sum_into(self, ref: ti.template(), value):
        """ref += value.  In the fused serial mode every kernel of the solver is one task on
        one thread, so the add is plain, also where the task is a member of a parallel
        :class:`Batch` (whose tasks are parallel: Taichi would keep the atomic); else an
        atomic add (Taichi demotes it where the loop is serial or ref belongs to one
        iteration)."""
        if ti.static(self.mode == "serial"):
            ref = ref + value
        else:
            ref += value

    @ti.func
    def _one_task(self, body: ti.template()):
        """Run ``body`` as one serial task in the fused serial mode, else as it is."""
        if ti.static(self.mode == "serial"):
            ti.loop_config(serialize=True)
            for _ in range(1):
                body()
        else:
            body()

    @ti.func
    def _is_fixed(self, I):
        fixed = 0
        if ti.static(len(self.fixed_nodes) > 0):
            fixed = self.fixed[I]
        return fixed

    @ti.func
    def _wall(self, I, v):
        """Wall conditions on the velocity of node I (sides left/right, bottom/top, ...):
        sticky v = 0; slip removes the outward normal component; friction also slows the
        tangential velocity by mu |v_n| (Coulomb), down to rest."""
        for k in ti.static(range(self.dim)):
            c = I[k] - self.node_offset - self.pad  # node coordinate, cells from the lower wall
            for side in ti.static(range(2)):
                kind, mu = ti.static(self.walls[2 * k + side])
                hit = c <= 0 if ti.static(side == 0) else c >= self.domain_cells[k]
                if hit:
                    vn = v[k] if ti.static(side == 0) else -v[k]  # along the inward normal
                    if ti.static(kind == "sticky"):
                        v = ti.Vector.zero(float, self.dim)
                    elif vn < 0.0:
                        if ti.static(kind == "friction"):
                            vt = v
                            vt[k] = 0.0
                            speed = vt.norm()
                            scale = 0.0
                            if speed > 0.0:
                                scale = ti.max(0.0, 1.0 - mu * (-vn) / speed)
                            v = vt * scale
                        else:
                            v[k] = 0.0
        return v

    @ti.func
    def _material_update(self, p, grad_du, sig_old):
        """New Cauchy stress from the particle's material (one compiled unit per material)."""
        sig_new = sig_old
        if ti.static(not self.multi_material):
            sig_new = self.materials[0].update(self, p, grad_du, sig_old)
        else:
            for k in ti.static(range(len(self.materials))):
                if self.mat[p] == k:
                    sig_new = self.materials[k].update(self, p, grad_du, sig_old)
        return sig_new

    # ---- phases of one step ------------------------------------------------------------
    @ti.func
    def _clear_grid(self):
        for I in ti.grouped(ti.ndrange(*self.grid_nodes)):
            self.gm[I] = 0.0
            self.gp[I] = ti.Vector.zero(float, self.dim)
            if ti.static(not self.apic):
                self.gf[I] = ti.Vector.zero(float, self.dim)
        if ti.static(self.consistent):
            for i, k in ti.ndrange(self.n_nodes, 2 * self.bandwidth + 1):
                self.band[i, k] = 0.0
        if ti.static(self.mls):
            for e, g in ti.ndrange(self.n_elements, ti.static(len(GAUSS_POINTS))):
                self.g_mom[e, g] = ti.Vector.zero(float, 3)
                self.g_rho[e, g] = ti.Vector.zero(float, 2)
                self.g_sig[e, g] = ti.Vector.zero(float, 2)
            self.body[None] = ti.Vector([1e300, -1e300])
            for i in range(self.n_nodes):
                self.n_mom[i] = ti.Vector.zero(float, 3)
                self.n_vel[i] = ti.Vector.zero(float, 2)

    @ti.func
    def _add(self, name: ti.template(), copy, node, value):
        """grid field ``name`` at ``node`` += value, by the scatter strategy: into the
        calling thread's private copy (plain adds) or the grid itself (atomic in a
        parallel loop, plain in a serial one)."""
        if ti.static(self.private_scatter):
            fld = ti.static(self.copies[name])
            at = self._copy_index(copy, node)
            fld[at] = fld[at] + value
        else:
            self._sum_into(ti.static(getattr(self, name))[node], value)

    @ti.func
    def _copy_index(self, copy, node):
        """Index of ``node`` in private copy ``copy``."""
        at = ti.Vector.zero(ti.i32, self.dim + 1)
        at[0] = copy
        for k in ti.static(range(self.dim)):
            at[k + 1] = node[k]
        return at

    @ti.func
    def _merged(self, name: ti.template(), I):
        """Grid quantity ``name`` at node I: with the private scatter the sum of the
        threads' copies (cleared for the next scatter), else the grid field itself."""
        total = ti.static(getattr(self, name))[I]
        if ti.static(self.private_scatter):
            fld = ti.static(self.copies[name])
            for c in ti.static(range(self.n_copies)):
                at = self._copy_index(c, I)
                if ti.static(c == 0):
                    total = fld[at]
                else:
                    total += fld[at]
                if ti.static(name == "gm"):
                    fld[at] = 0.0
                else:
                    fld[at] = ti.Vector.zero(float, self.dim)
        return total

    @ti.func
    def _merge_copies(self, names: ti.template()):
        # private scatter: sum the threads' grid copies into the grid, and clear them
        for I in ti.grouped(ti.ndrange(*self.grid_nodes)):
            for name in ti.static(names):
                grid = ti.static(getattr(self, name))
                grid[I] = self._merged(name, I)  # a plain store: no other thread writes I

    @ti.func
    def _scatter_particles(self, phase: ti.template()):
        """Run the scattering particle phase ("p2g" or "g2p-velocity") for every particle,
        by the scatter strategy."""
        if ti.static(self.private_scatter):
            # Taichi's CPU range-for gives thread c the iterations [c B, (c + 1) B) with
            # B = max(ceil(N / threads), 512): iteration p writes the copy of thread p // B
            B = ti.static(self.scatter_block)
            for p in range(self.n_copies * B):
                if p < self.n_particles:
                    self._scatter_particle(phase, p, p // B)
        elif ti.static(self.run_sums):
            ti.loop_config(serialize=True)
            for _ in range(1):  # one task: the sums stay in registers
                rows = ti.static(self.scatter_rows[phase])
                first = -1  # first node of the run's stencil
                sums = ti.Matrix.zero(float, 3, self.basis.support)
                for p in range(self.n_particles):
                    base, inside, node_values = self._scatter_particle(phase, p, 0)
                    if inside:
                        if base[0] != first:
                            self._add_sums(rows, first, sums)
                            first = base[0]
                            sums = ti.Matrix.zero(float, 3, self.basis.support)
                        sums += node_values
                self._add_sums(rows, first, sums)
        elif ti.static(self.serial_scatter):
            ti.loop_config(serialize=True)  # plain adds instead of contended atomics
            for p in range(self.n_particles):
                self._scatter_particle(phase, p, 0)
        else:
            for p in range(self.n_particles):
                self._scatter_particle(phase, p, 0)

    @ti.func
    def _scatter_particle(self, phase: ti.template(), p, copy):
        """The particle's stencil base, whether it scattered, and (run sums) its node
        values: rows gm, gf, gp, one column per stencil node."""
        base = ti.Vector.zero(ti.i32, self.dim)
        inside = 0
        node_values = ti.Matrix.zero(float, 3, self.basis.support)
        if not self._halted(p):
            if ti.static(phase == "p2g"):
                base, inside, node_values = self._p2g_particle(p, copy)
            else:
                base, inside, node_values = self._g2p_velocity_particle(p, copy)
        return base, inside, node_values

    @ti.func
    def _add_sums(self, rows: ti.template(), first, sums):
        """Add a run's node sums to the grid nodes first, first + 1, ... (none if first < 0)."""
        if first >= 0:
            for name in ti.static(rows):
                row = ti.static(SUM_ROWS[name])
                for a in ti.static(range(self.basis.support)):
                    if ti.static(name == "gm"):
                        self._sum_into(self.gm[first + a], sums[row, a])
                    else:
                        self._sum_into(ti.static(getattr(self, name))[first + a][0], sums[row, a])

    @ti.func
    def _deposit(self, name: ti.template(), copy, node, offset: ti.template(), value,
                 node_values):
        """Scatter ``value`` to grid field ``name`` at ``node``: into the run sums' column
        ``offset`` (returned), or by the scatter strategy (``_add``)."""
        if ti.static(self.run_sums):
            if ti.static(name == "gm"):
                node_values[SUM_ROWS[name], offset[0]] = value
            else:
                node_values[SUM_ROWS[name], offset[0]] = value[0]
        else:
            self._add(name, copy, node, value)
        return node_values

    @ti.func
    def _halted(self, p):
        """A step before this one failed: the particles stay as they were at the failure
        (Python reads the error back every ``check_every`` steps).  The fused serial mode
        stops before the step after a failure instead (see ``_advance``), a team at the
        first barrier after it (its step is that of particle p's thread)."""
        halted = False
        if ti.static(self.team):
            halted = (self.err_count[None] != 0 and
                      self.err_step[None] < self.rank_step[p // self.scatter_block])
        elif ti.static(self.mode != "serial"):
            halted = self.err_count[None] != 0 and self.err_step[None] < self.step_count[None]
        return halted

    @ti.func
    def _p2g(self):
        # P2G (2.2.4): M_ij = sum m_p phi_i phi_j (A.1) or M_ii = sum m_p phi_i (A.2);
        # F_i = sum phi_i (m_p g + f_trac(t)) - sigma_p V_p dphi_i; with the affine transfer
        # (APIC) P_i = sum m_p phi_i (v_p + C_p (x_i - x_p)) + dt F_i in the same pass
        self._scatter_particles("p2g")
        if ti.static(self.private_scatter and not self.apic):
            self._merge_copies(ti.static(tuple(self.copies)))  # the affine grid pass sums them

    @ti.func
    def _p2g_particle(self, p, copy):
        base, w, dw, xi, inside = self._stencil(p)
        node_values = ti.Matrix.zero(float, 3, self.basis.support)
        if not inside:
            self._fail(1, p)
        else:
            mp = self.m[p]
            fp = ti.Vector.zero(float, self.dim)
            for k in ti.static(range(self.dim)):
                if ti.static(self.gravity[k] != 0.0):
                    fp[k] += mp * self.gravity[k]
            if ti.static(self.has_traction):
                if p == self.traction_particle:
                    fp[0] += self.traction_amplitude * self.traction_fn.value(self.time[None])
            stress_volume = self.sigma[p] * self.vol[p]
            affine = ti.Matrix.zero(float, self.dim, self.dim)
            if ti.static(self.mls_mpm):
                affine = mp * self.C[p] - (self.dt * self.D_inv) * stress_volume
            if ti.static(self.mls):
                fp[0] -= mp * self.gravity[0]  # gravity and mass come from the Gauss points
                self._scatter_gauss_moments(p)
            # the affine momentum A (x_i - x_p) with x_i - x_p = h o - d (o: the node's
            # offset in the stencil) is h A o - A d: one vector per particle, then adds
            d = self._from_first_node(xi, base)
            if ti.static(self.apic and not self.mls_mpm and self.basis.support > 2):
                affine = mp * self.C[p]  # APIC: the stress enters through grad phi
            mom = mp * self.v[p] + self.dt * fp - affine @ d
            h_affine = self.h * affine
            for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                phi, grad = self._weight(w, dw, offset)
                node = base + offset
                if ti.static(self.mls_mpm):
                    self._add("gm", copy, node, mp * phi)
                    self._add("gp", copy, node, phi * (mom + self._times_offset(h_affine, offset)))
                elif ti.static(self.apic):
                    # m_p C_p (x_i - x_p) phi_i; the linear basis keeps B_p in C and applies
                    # D_p^-1 at the new position: B_p D_p^-1 (x_i - x_p) phi_i = B_p grad phi_i
                    # (Jiang et al. 2015), bounded where a particle barely touches a node
                    momentum = ti.Vector.zero(float, self.dim)
                    if ti.static(self.basis.support > 2):
                        momentum = phi * (mom + self._times_offset(h_affine, offset))
                    else:
                        momentum = phi * (mp * self.v[p] + self.dt * fp) + mp * (self.C[p] @ grad)
                    self._add("gm", copy, node, mp * phi)
                    self._add("gp", copy, node, momentum - self.dt * (stress_volume @ grad))
                elif ti.static(not self.mls):
                    node_values = self._deposit("gm", copy, node, offset, mp * phi, node_values)
                    node_values = self._deposit("gf", copy, node, offset,
                                                phi * fp - stress_volume @ grad, node_values)
                else:
                    self._sum_into(self.gf[node], phi * fp)
                if ti.static(not self.apic and (self.damping > 0.0 or self.has_walls)):
                    node_values = self._deposit("gp", copy, node, offset, mp * phi * self.v[p],
                                                node_values)
            if ti.static(self.consistent):
                for a, c in ti.static(ti.ndrange(self.basis.support, self.basis.support)):
                    self._sum_into(self.band[base[0] + a, c - a + self.bandwidth],
                                   mp * w[a, 0] * w[c, 0])
        return base, inside, node_values

    @ti.func
    def _grid_acceleration(self):
        # grid: local damping F_damp = -alpha sgn(v_i) |F_i| (A.4), then a = M^-1 F; at a
        # wall a = (wall(v_i + dt a) - v_i) / dt with v_i = P_i / m_i
        for I in ti.grouped(ti.ndrange(*self.grid_nodes)):
            if ti.static(self.damping > 0.0):
                self.gf[I] -= self.damping * ti.math.sign(self.gp[I]) * ti.abs(self.gf[I])
            if ti.static(self.has_walls):
                a = ti.Vector.zero(float, self.dim)
                if self.gm[I] > self.mass_tol:
                    vn = self.gp[I] / self.gm[I]
                    a = (self._wall(I, vn + self.dt * self.gf[I] / self.gm[I]) - vn) / self.dt
                self.gf[I] = a
            elif ti.static(not self.consistent):
                self.gf[I] = self._lumped_solve(I, self.gf[I])  # a = F / m in the same pass
            if ti.static(self.damping > 0.0 or self.has_walls):
                self.gp[I] = ti.Vector.zero(float, self.dim)  # P2G scattered P_i
        if ti.static(self.consistent and not self.has_walls):
            self._solve_mass(self.gf, False)

    @ti.func
    def _grid_velocity(self):
        # grid (APIC): v_i = P_i / m_i, wall conditions applied; in the same pass the
        # private copies are summed in and m_i, P_i cleared for the next P2G
        # (a node no particle reached has m = P = 0 and is left alone: G2P weighs it by 0)
        for I in ti.grouped(ti.ndrange(*self.grid_nodes)):
            self._grid_velocity_node(I)

    @ti.func
    def _grid_velocity_node(self, I):
        if self._reached(I):
            m = self._merged("gm", I)
            P = self._merged("gp", I)
            v = ti.Vector.zero(float, self.dim)
            if m > self.mass_tol and not self._is_fixed(I):
                v = P / m
                if ti.static(self.has_walls):
                    v = self._wall(I, v)
            self.gv[I] = v
            if ti.static(self.strain_remap):
                self.gm[I] = m  # P cleared for the remap
                self.gp[I] = ti.Vector.zero(float, self.dim)
            elif ti.static(not self.private_scatter):
                self.gm[I] = 0.0
                self.gp[I] = ti.Vector.zero(float, self.dim)

    @ti.func
    def _reached(self, I):
        """Whether a particle scattered mass to node I (in any private copy)."""
        reached = False
        if ti.static(self.private_scatter):
            for c in ti.static(range(self.n_copies)):
                reached = reached or self.copies["gm"][self._copy_index(c, I)] != 0.0
        else:
            reached = self.gm[I] != 0.0
        return reached

    @ti.func
    def _g2p_velocity(self):
        # G2P: v_p += dt sum_i phi_i(x_p) a_i (APIC: v_p = sum_i phi_i v_i, C_p);
        # P2G: P_i = sum m_p phi_i(x_p) v_p (2.2.4)
        self._scatter_particles("g2p-velocity")
        if ti.static(self.private_scatter):
            self._merge_copies(("gp",))

    @ti.func
    def _g2p_velocity_particle(self, p, copy):
        base, w, dw, xi, inside = self._stencil(p)
        node_values = ti.Matrix.zero(float, 3, self.basis.support)
        if inside:
            vp = ti.Vector.zero(float, self.dim)
            if ti.static(self.apic):
                # APIC (the strain remap): v_p = sum_i phi_i v_i, C_p = B_p as in _g2p_update
                B = ti.Matrix.zero(float, self.dim, self.dim)
                vp, B, _ = self._affine_gather(base, w, dw, xi, False)
                self.C[p] = B  # the linear basis keeps B_p (see _p2g)
            else:
                acc = ti.Vector.zero(float, self.dim)
                for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                    phi, grad = self._weight(w, dw, offset)
                    acc += phi * self.gf[base + offset]
                vp = self.v[p] + self.dt * acc
            self.v[p] = vp
            if ti.static(self.mls):
                self._scatter_node_moments(p, vp[0])
            else:
                for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                    phi, grad = self._weight(w, dw, offset)
                    node_values = self._deposit("gp", copy, base + offset, offset,
                                                self.m[p] * phi * vp, node_values)
        return base, inside, node_values

    @ti.func
    def _affine_gather(self, base, w, dw, xi, gradient: ti.template()):
        """G2P of the grid velocity (affine transfers): v_p = sum_i phi_i v_i, B_p = sum_i
        phi_i v_i (x_i - x_p)^T and, with ``gradient``, grad du = sum_i v_i dt grad phi_i^T."""
        vp = ti.Vector.zero(float, self.dim)
        grad_du = ti.Matrix.zero(float, self.dim, self.dim)
        B = ti.Matrix.zero(float, self.dim, self.dim)  # sum_i phi_i v_i o_i^T
        for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
            phi, grad = self._weight(w, dw, offset)
            vi = self.gv[base + offset]
            vp += phi * vi
            if ti.static(gradient):
                grad_du += (vi * self.dt).outer_product(grad)
            B += self._outer_offset(phi * vi, offset)
        # sum_i phi_i v_i (x_i - x_p)^T = h sum_i phi_i v_i o_i^T - v_p d^T
        d = self._from_first_node(xi, base)
        return vp, self.h * B - vp.outer_product(d), grad_du

    @ti.func
    def _g2p_update(self):
        # G2P: du_p = sum_i phi_i v_i dt (u_p, x_p); grad du = sum_i v_i dt dphi_i^T;
        # stress from the material (2.2.4 in 1D); V *= det(I + grad du); with the affine
        # transfer v_p = sum_i phi_i v_i and C_p = sum_i phi_i v_i (x_i - x_p)^T D_p^-1
        for p in range(self.n_particles):
            self._g2p_update_particle(p)

    @ti.func
    def _g2p_update_particle(self, p):
        base, w, dw, xi, inside = self._stencil(p)
        if inside and not self._halted(p):
            vp = ti.Vector.zero(float, self.dim)
            grad_du = ti.Matrix.zero(float, self.dim, self.dim)
            if ti.static(self.strain_remap):
                vp = self.v[p]  # v_p and C_p came with the remap (_g2p_velocity)
                for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                    phi, grad = self._weight(w, dw, offset)
                    grad_du += (self.gp[base + offset] * self.dt).outer_product(grad)
            elif ti.static(self.apic):
                B = ti.Matrix.zero(float, self.dim, self.dim)
                vp, B, grad_du = self._affine_gather(base, w, dw, xi, not self.mls_mpm)
                self.v[p] = vp
                if ti.static(self.mls_mpm):
                    self.C[p] = B * self.D_inv
                    grad_du = self.C[p] * self.dt
                else:
                    # D_p = sum_i phi_i (x_i - x_p)(x_i - x_p)^T: diagonal for tensor
                    # products of a basis reproducing linear fields
                    for k in ti.static(range(self.dim)):
                        dk = 0.0
                        for a in ti.static(range(self.basis.support)):
                            r = (base[k] + a - self.node_offset - xi[k]) * self.h
                            dk += w[a, k] * r * r
                        for j in ti.static(range(self.dim)):
                            B[j, k] /= dk
                    self.C[p] = B
            else:
                for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                    phi, grad = self._weight(w, dw, offset)
                    vi = self.gp[base + offset]
                    vp += phi * vi
                    grad_du += (vi * self.dt).outer_product(grad)
            du = vp * self.dt
            deps = 0.5 * (grad_du + grad_du.transpose())
            vol_old = self.vol[p]
            sig_old = self.sigma[p]
            jac = 1.0
            vol_new = vol_old
            if ti.static(self.update_volume):
                jac = 1.0 + grad_du[0, 0]
                if ti.static(self.dim > 1):
                    jac = (ti.Matrix.identity(float, self.dim) + grad_du).determinant()
                vol_new = vol_old * jac
                self.vol[p] = vol_new  # the materials read the new volume
            sig_new = self._material_update(p, grad_du, sig_old)
            self.sigma[p] = sig_new
            if ti.static(self.record_energies):
                # strain energy: trapezoidal path integral of sigma : d_eps V
                self._sum_into(self.work[p],
                               0.5 * ((sig_old * vol_old + sig_new * vol_new) * deps).sum())
                if ti.static(self.has_traction):
                    if p == self.traction_particle:
                        self._sum_into(self.ext_work[None], self.traction_amplitude *
                                       self.traction_fn.value(self.time[None]) * du[0])
            if ti.static(self.has_u):
                self._sum_into(self.u[p], du)
            x_new = self.x[p] + du
            self.x[p] = x_new
            # checks on the new state, from registers (a NaN in the MUSL particle velocity
            # reaches vp through the grid); the first failure of the run is the one reported
            xn = ti.Vector.zero(float, self.dim)
            code = 0
            for k in ti.static(range(self.dim)):
                xn[k] = (x_new[k] - self.origin[k]) * self.inv_h
                if not (xn[k] >= 0.0 and xn[k] <= self.grid_elements[k]):
                    code = 1
            if ti.static(self.update_volume):
                if not (jac > 0.0):
                    code = 3
            state = x_new.sum() + vp.sum() + sig_new.sum() + vol_new
            if not (ti.abs(state) < 1e300):  # NaN fails this comparison
                code = 2
            if code != 0:
                self._fail(code, p)
            if ti.static(self.track_crossings):
                e = self._element(xn)
                if (e != self.elem[p]).any():
                    self._sum_into(self.crossings[None], 1)
                    self.elem[p] = e

    @ti.func
    def _solve_mass(self, rhs: ti.template(), walls: ti.template()):
        """rhs <- M^-1 rhs with Dirichlet nodes held at zero and empty nodes left at zero;
        ``walls``: apply the wall conditions to the result (a velocity)."""
        if ti.static(not self.consistent):
            for I in ti.grouped(ti.ndrange(*self.grid_nodes)):
                rhs[I] = self._lumped_solve(I, rhs[I])
                if ti.static(walls and self.has_walls):
                    rhs[I] = self._wall(I, rhs[I])
        else:
            self._banded_substitute(rhs)

    @ti.func
    def _lumped_solve(self, I, value):
        """value / m_i at node I; zero at Dirichlet and empty nodes."""
        out = ti.Vector.zero(float, self.dim)
        if not (self._is_fixed(I) or self.gm[I] <= self.mass_tol):
            out = value / self.gm[I]
        return out

    @ti.func
    def _banded_factorise(self):
        # consistent mass (A.1): banded LU without pivoting, in place, on one thread; fixed
        # and empty rows become identity rows (their right-hand sides are zeroed)
        b, nn = ti.static(self.bandwidth, self.n_nodes)
        for _ in range(1):
            for i in range(nn):
                self.inactive[i] = 0
                if self._is_fixed(i) or self.band[i, b] <= self.mass_tol:
                    self.inactive[i] = 1
                    for k in ti.static(range(2 * b + 1)):
                        self.band[i, k] = 0.0
                    for r in ti.static(range(1, b + 1)):
                        if i - r >= 0:
                            self.band[i - r, b + r] = 0.0
                        if i + r < nn:
                            self.band[i + r, b - r] = 0.0
                    self.band[i, b] = 1.0
            for k in range(nn):
                pivot = self.band[k, b]
                if ti.abs(pivot) <= self.pivot_tol:
                    self._fail(4, k)
                    pivot = 1.0
                    self.band[k, b] = 1.0
                if pivot < 0.0:
                    self._sum_into(self.neg_pivots[None], 1)
                for r in ti.static(range(1, b + 1)):
                    i = k + r
                    if i < nn:
                        lik = self.band[i, b - r] / pivot
                        self.band[i, b - r] = lik  # the multiplier, kept for substitution
                        for c in ti.static(range(1, b + 1)):
                            if c - r <= b:
                                self.band[i, b - r + c] -= lik * self.band[k, b + c]

    @ti.func
    def _banded_substitute(self, rhs: ti.template()):
        b, nn = ti.static(self.bandwidth, self.n_nodes)
        for _ in range(1):
            for i in range(nn):
                if self.inactive[i]:
                    rhs[i] = ti.Vector.zero(float, self.dim)
            for i in range(nn):  # forward: L y = rhs
                acc = rhs[i]
                for r in ti.static(range(1, b + 1)):
                    if i - r >= 0:
                        acc -= self.band[i, b - r] * rhs[i - r]
                rhs[i] = acc
            for j in range(nn):  # backward: U x = y
                i = nn - 1 - j
                acc = rhs[i]
                for c in ti.static(range(1, b + 1)):
                    if i + c < nn:
                        acc -= self.band[i, b + c] * rhs[i + c]
                rhs[i] = acc / self.band[i, b]

    @ti.func
    def _one_step(self):
        if ti.static(self.apic):
            # affine transfer: P2G of mass and momentum + dt force, v = P / m (the grid
            # pass leaves m and P cleared: no separate clearing pass), G2P
            if ti.static(self.strain_remap):
                self._clear_grid()  # m_i stays for the remap
            self._p2g()
            self._grid_velocity()
            if ti.static(self.strain_remap):
                # G2P of v_p and C_p, P'_i = sum m_p phi_i v_p, v'_i = P'_i / m_i
                self._g2p_velocity()
                self._solve_mass(self.gp, True)
            self._g2p_update()
        else:
            self._clear_grid()
            # the study's MUSL scheme with Euler-Cromer stepping (2.2.4, Figure 2.7)
            if ti.static(self.mls):
                self._body_extent()
            self._p2g()
            if ti.static(self.mls):
                self._integrate_gauss()
            if ti.static(self.consistent):
                self._banded_factorise()
            self._grid_acceleration()
            self._g2p_velocity()
            if ti.static(self.mls):
                self._mls_nodal_velocity()
            else:
                self._solve_mass(self.gp, True)
            if ti.static(self.grid_displacement):
                for I in ti.grouped(ti.ndrange(*self.grid_nodes)):
                    self._sum_into(self.gu[I], self.gp[I] * self.dt)  # u_i += v_i dt (5.2)
            self._g2p_update()
        if not self._halted(0):
            self._sum_into(self.step_count[None], 1)
            self.time[None] = self.step_count[None] * self.dt

    # ---- moving-least-squares projection (study 4.4) -----------------------------------
    @ti.func
    def _scatter_gauss_moments(self, p):
        # MLS moments at the Gauss points within 1.5 h of the particle, quadratic-spline
        # weight, basis [1, d] with d = (x_p - y) / h
        xi = (self.x[p][0] - self.origin[0]) * self.inv_h
        e0 = ti.floor(xi, ti.i32)
        rho = self.m[p] / self.vol[p]
        sig = self.sigma[p][0, 0]
        for k in ti.static(range(-2, 3)):
            e = e0 + k
            if 0 <= e < self.n_elements:
                for g in ti.static(range(len(GAUSS_POINTS))):
                    y, jw = self._gauss_point(e, g)
                    d = xi - y
                    w = _quadratic_spline(ti.abs(d)) if jw > 0.0 else 0.0
                    if w > 0.0:
                        self._sum_into(self.g_mom[e, g], w * ti.Vector([1.0, d, d * d]))
                        self._sum_into(self.g_rho[e, g], w * rho * ti.Vector([1.0, d]))
                        self._sum_into(self.g_sig[e, g], w * sig * ti.Vector([1.0, d]))

    @ti.func
    def _body_extent(self):
        # the body is the union of the particle domains x_p -+ V_p / 2 (element units)
        for p in range(self.n_particles):
            xi = (self.x[p][0] - self.origin[0]) * self.inv_h
            half = 0.5 * self.vol[p] * self.inv_h
            if ti.static(self.mode == "serial"):  # one thread: no atomics (see _sum_into)
                self.body[None][0] = ti.min(self.body[None][0], xi - half)
                self.body[None][1] = ti.max(self.body[None][1], xi + half)
            else:
                ti.atomic_min(self.body[None][0], xi - half)
                ti.atomic_max(self.body[None][1], xi + half)

    @ti.func
    def _gauss_point(self, e, g: ti.template()):
        """Gauss point g of element e's part of the body, and its weight times length."""
        a = ti.max(ti.cast(e, float), self.body[None][0])
        b = ti.min(ti.cast(e + 1, float), self.body[None][1])
        return a + (b - a) * GAUSS_POINTS[g], GAUSS_WEIGHTS[g] * ti.max(b - a, 0.0) * self.h

    @ti.func
    def _integrate_gauss(self):
        # M_ii = int rho phi_i, F_i = int (rho g phi_i - sigma dphi_i) by Gauss quadrature
        # over each element's part of the body, rho and sigma reconstructed by MLS (4.4)
        for e in range(self.n_elements):
            for g in ti.static(range(len(GAUSS_POINTS))):
                y, jw = self._gauss_point(e, g)
                if jw > 0.0:
                    rho = _mls_value(self.g_mom[e, g], self.g_rho[e, g])
                    sig = _mls_value(self.g_mom[e, g], self.g_sig[e, g])
                    base, w, dw = self.basis.stencil(y, self.n_elements)
                    for a in ti.static(range(self.basis.support)):
                        self._sum_into(self.gm[base + a], jw * rho * w[a])
                        self._sum_into(self.gf[base + a][0], jw * (rho * self.gravity[0] * w[a]
                                                                   - sig * dw[a] * self.inv_h))

    @ti.func
    def _scatter_node_moments(self, p, vp):
        # MLS moments at the nodes within 2 h, cubic-spline weight (r = |d| / 2)
        xi = (self.x[p][0] - self.origin[0]) * self.inv_h
        i0 = ti.floor(xi, ti.i32)
        for k in ti.static(range(-1, 3)):
            i = i0 + k
            if 0 <= i < self.n_nodes:
                d = xi - i
                w = _cubic_spline(0.5 * ti.abs(d))
                if w > 0.0:
                    self._sum_into(self.n_mom[i], w * ti.Vector([1.0, d, d * d]))
                    self._sum_into(self.n_vel[i], w * vp * ti.Vector([1.0, d]))

    @ti.func
    def _mls_nodal_velocity(self):
        # v_i = sum_p Phi_p(x_i) v_p: the MLS reconstruction of the velocity field (4.4)
        for i in range(self.n_nodes):
            v = 0.0
            if not self._is_fixed(i):
                v = _mls_value(self.n_mom[i], self.n_vel[i])
            self.gp[i][0] = v

    # ---- recording ---------------------------------------------------------------------
    @ti.func
    def _record(self):
        slot = self.rec_count[None]
        self.h_t[slot] = self.time[None]
        self.h_step[slot] = self.step_count[None]
        if ti.static(self.n_tracked > 0):
            for j in range(self.n_tracked):
                p = self.track_ids[j]
                self.h_x[slot, j] = self.x[p]
                if ti.static(self.has_u):
                    self.h_u[slot, j] = self.u[p]
                self.h_v[slot, j] = self.v[p]
                self.h_s[slot, j] = self.sigma[p]
        if ti.static(self.record_energies):
            self.h_energy[slot] = ti.Vector.zero(float, 4)
            for p in range(self.n_particles):
                # potential of gravity: -m g . u (1D), -m g . x (2D/3D, taken from its start in energies())
                pot = 0.0
                for k in ti.static(range(self.dim)):
                    if ti.static(self.gravity[k] != 0.0):
                        if ti.static(self.has_u):
                            pot -= self.m[p] * self.gravity[k] * self.u[p][k]
                        else:
                            pot -= self.m[p] * self.gravity[k] * self.x[p][k]
                e = ti.Vector([0.5 * self.m[p] * self.v[p].norm_sqr(), self.work[p], pot, 0.0])
                self._sum_into(self.h_energy[slot], e)
            if ti.static(self.has_traction):
                self.h_energy[slot][3] = self.ext_work[None]
        self.rec_count[None] = slot + 1

    @ti.func
    def _clear_and_project(self):
        self._clear_grid()
        self._project()

    @ti.func
    def _project(self):
        # P2G of mass and momentum alone: m_i = sum m_p phi_i, P_i = sum m_p phi_i v_p
        for p in range(self.n_particles):
            base, w, dw, xi, inside = self._stencil(p)
            if inside:
                for offset in ti.static(ti.grouped(ti.ndrange(*((self.basis.support,) * self.dim)))):
                    phi, grad = self._weight(w, dw, offset)
                    self._sum_into(self.gm[base + offset], self.m[p] * phi)
                    self._sum_into(self.gp[base + offset], self.m[p] * phi * self.v[p])

    # ---- kernels -----------------------------------------------------------------------
    @ti.kernel
    def _project_kernel(self):
        self._one_task(self._clear_and_project)

    @ti.kernel
    def _clear_kernel(self):
        self._clear_grid()

    def _bind_launchers(self):
        """The per-step kernels as plain kernels closed over this solver: a method kernel
        of a data-oriented class maps ``self`` to its compiled instance on every call,
        which doubled the launch (~27 against ~15 us, most of a small scene's step)."""
        @ti.kernel
        def step():
            self._one_step()

        @ti.kernel
        def record():
            self._one_task(self._record)

        self._step, self._record_kernel = step, record
        if self.team:
            @ti.kernel
            def team(n_steps: ti.i32):
                self._team_steps(n_steps)

            self._team = team

    def _launch(self, n: int):
        """n steps of the parallel mode: one launch for a team, else one launch per step."""
        if self.team:
            self._team(n)
        else:
            for _ in range(n):
                self._step()

    @ti.kernel
    def _advance(self, n_steps: ti.i32, every: ti.i32) -> ti.i32:
        done = 0
        ti.loop_config(serialize=True)
        for _ in range(1):  # one task on one thread: the fused serial mode
            done = self._advance_steps(n_steps, every)
        return done

    @ti.func
    def _advance_steps(self, n_steps, every):
        """Up to n_steps steps, recording every ``every``-th; stops before the step after
        a failure.  Returns the steps done (the body of ``_advance`` and of a Batch)."""
        done = 0
        for _ in range(n_steps):
            if self.err_count[None] != 0:  # no step after a failed one
                break
            self._one_step()
            done += 1
            if ti.static(self.recording):
                if self.step_count[None] % every == 0:
                    self._record()
        return done

    # ---- team mode: the passes of many steps in one parallel task ----------------------
    @ti.func
    def _team_steps(self, n_steps):
        self.team_arrived[None] = 0
        self.team_abort[None] = 0
        B = ti.static(self.scatter_block)
        for q in range(self.n_copies * B):
            if q % B == 0:  # thread q // B of Taichi's static split runs its whole block
                self._team_member(q // B, n_steps)

    @ti.func
    def _team_member(self, c, n_steps):
        """Thread c of the team: n_steps affine steps on its particles [c B, (c + 1) B)
        (scattered into its grid copy) and its share of the nodes."""
        n_nodes = ti.static(int(np.prod(self.grid_nodes)))
        nodes_per_thread = ti.static(-(-n_nodes // self.n_copies))
        first, end = c * self.scatter_block, ti.min((c + 1) * self.scatter_block, self.n_particles)
        start = self.step_count[None]  # thread 0 changes it only after the second barrier
        arrivals = 0
        for s in range(n_steps):
            self.rank_step[c] = start + s
            # P2G of the thread's particles into its own grid copy (as _p2g)
            for p in range(first, end):
                self._scatter_particle("p2g", p, c)
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            # all threads read the same errors here: the next is written in G2P, after the
            # next barrier
            if (ti.atomic_add(self.err_count[None], 0) != 0
                    or ti.atomic_add(self.team_abort[None], 0) != 0):
                break
            # grid: the copies summed, v = P / m, walls, on the thread's nodes (as
            # _grid_velocity)
            for f in range(c * nodes_per_thread, ti.min((c + 1) * nodes_per_thread, n_nodes)):
                self._grid_velocity_node(self._node_of(f))
            arrivals += self.n_copies
            self._team_barrier(c, arrivals)
            if ti.atomic_add(self.team_abort[None], 0) != 0:
                break
            # G2P of the thread's particles (as _g2p_update): the next P2G reads only them
            for p in range(first, end):
                self._g2p_update_particle(p)
            if c == 0:
                self.step_count[None] = start + s + 1
                self.time[None] = (start + s + 1) * self.dt

    @ti.func
    def _team_barrier(self, c, target):
        """Arrive, then spin until ``target`` arrivals (every thread of the team is here);
        after TEAM_SPIN_LIMIT spins (a thread that never came) fail with error 6."""
        ti.atomic_add(self.team_arrived[None], 1)
        spins = 0
        while ti.atomic_add(self.team_arrived[None], 0) < target:
            spins += 1
            if spins % 1024 == 0:
                if ti.atomic_add(self.team_abort[None], 0) != 0:
                    break
                if spins > TEAM_SPIN_LIMIT:
                    ti.atomic_add(self.team_abort[None], 1)
                    self._fail(6, c * self.scatter_block)
                    break

    @ti.func
    def _node_of(self, f):
        """Grid index of the node at flat index f (the order of ti.ndrange)."""
        I = ti.Vector.zero(ti.i32, self.dim)
        rest = f
        for k in ti.static(range(self.dim - 1, -1, -1)):
            I[k] = rest % self.grid_nodes[k]
            rest = rest // self.grid_nodes[k]
        return I

    # ---- Python driver -----------------------------------------------------------------
    @property
    def step(self) -> int:
        self._require_fields()
        return int(self.step_count[None])

    @property
    def t(self) -> float:
        self._require_fields()
        return float(self.time[None])

    def steps_for(self, t_end: float) -> int:
        """Number of steps of size dt that reach ``t_end`` (rounded to the nearest step)."""
        if not np.isfinite(t_end) or t_end < 0:
            raise ValueError(f"t_end must be a non-negative finite time, got {t_end!r}")
        return int(round(t_end / self.dt))

    def compile(self):
        """Compile the kernels this run needs (timed apart as ``compile_seconds``)."""
        if self._compiled:
            return
        t0 = time.perf_counter()
        if self.mode == "serial":
            self._advance(0, self.record_every)  # zero steps: compiles, changes nothing
        self._compile_io()
        self.compile_seconds += time.perf_counter() - t0
        self._compiled = True

    def _compile_io(self):
        """Compile the recording kernel and the accessors the drivers read with."""
        if self.recording:
            self._record_kernel()
            self.rec_count[None] = 0
            for _, fld in self._history_fields():
                fld.to_numpy()
        int(self.err[None]) + int(self.err_count[None])

    def run(self, t_end: float | None = None, n_steps: int | None = None, progress=None):
        """Advance to ``t_end`` (or by ``n_steps``); returns self.

        Raises :class:`SimulationError` at the first step whose state is invalid.  A
        progress line is drawn on stderr for runs that last more than two seconds when
        stderr is a terminal (``progress=True`` forces it, ``False`` turns it off).
        Wall time spent stepping accumulates in ``run_seconds``; kernel compilation is
        booked apart in ``compile_seconds``.
        """
        self._require_fields()
        total = self._steps_to(t_end, n_steps)
        self.compile()
        self._record_start()
        bar = _Progress(total, progress)
        done = 0
        start = time.perf_counter()
        while done < total:
            if self.mode == "serial":
                chunk = self._fused_chunk(min(total - done, bar.suggested_chunk(done)))
                done += int(self._advance(chunk, self.record_every))
                self._drain()
                self._check()
            elif self._timed_steps < 2:
                t0 = time.perf_counter()
                self._launch(1)
                took = time.perf_counter() - t0
                # the first launch compiles: book its excess over the second apart
                if self._timed_steps == 0:
                    self._first_step = took
                else:
                    extra = max(self._first_step - took, 0.0)
                    self.compile_seconds += extra
                    start += extra
                self._timed_steps += 1
                done += 1
                self._check()
                self._record_step()
            else:
                # one launch per step (a team: one per chunk); the checks read back every
                # check_every steps (a failed particle is skipped by later steps, the first
                # failure is kept)
                chunk = min(total - done, self.check_every, bar.suggested_chunk(done))
                if self.recording:
                    chunk = min(chunk, self.record_every - self.step % self.record_every)
                self._launch(chunk)
                done += chunk
                self._check()
                self._record_step()
            bar.update(done)
        bar.close()
        self._record_end()
        self.run_seconds += time.perf_counter() - start
        return self

    def _steps_to(self, t_end, n_steps) -> int:
        """Steps a run to ``t_end`` (or of ``n_steps``) takes from here."""
        if (t_end is None) == (n_steps is None):
            raise ValueError("give exactly one of t_end and n_steps")
        total = self.steps_for(t_end) - self.step if n_steps is None else int(n_steps)
        if total < 0:
            raise ValueError(f"t_end = {t_end} lies before the current time {self.t}")
        return total

    def _fused_chunk(self, n: int) -> int:
        """At most n fused steps, fewer if the history buffer (history_chunk records)
        would overflow."""
        return min(n, self.history_chunk * self.record_every) if self.recording else n

    def _record_start(self):
        """Record the initial state before the first step."""
        if self.recording and self.step == 0 and not self.history["t"]:
            self._record_now()

    def _record_end(self):
        """Read back the records and record the final state if the last step was not."""
        if self.recording:
            self._drain()
            if self.history["step"][-1][-1] != self.step:
                self._record_now()

    def _record_step(self):
        if self.recording and self.step % self.record_every == 0:
            self._record_kernel()
            if self.rec_count[None] == self.history_chunk:
                self._drain()

    def _record_now(self):
        self._record_kernel()
        self._drain()

    def _history_fields(self):
        """(key, field) of every recorded quantity."""
        fields = [("t", self.h_t), ("step", self.h_step)]
        if self.record_energies:
            fields.append(("energy", self.h_energy))
        if self.n_tracked:
            fields += [("x", self.h_x), ("v", self.h_v), ("stress", self.h_s)]
            if self.has_u:
                fields.append(("u", self.h_u))
        return fields

    def _drain(self):
        """Move the records of the kernel's history buffer to ``self.history``."""
        if not self.recording:
            return
        n = int(self.rec_count[None])
        if n == 0:
            return
        # kept as one array per drain (rows one by one would cost more than the steps)
        chunk = {key: fld.to_numpy()[:n] for key, fld in self._history_fields()}
        for key, values in chunk.items():
            self.history.setdefault(key, []).append(values)
        self.rec_count[None] = 0
        if self.record_energies:
            self._guard_energy(chunk["energy"], chunk["step"])

    def _guard_energy(self, energy, steps):
        if self.energy_guard is None or not len(self.history["energy"]):
            return
        first = self.history["energy"][0][0]
        base = first[0] + max(first[1], 0.0)
        # energy put in: initial kinetic + strain, and the work of gravity and tractions
        supplied = base + np.abs(energy[:, 2] - first[2]) + np.abs(energy[:, 3] - first[3])
        supplied = np.maximum.accumulate(np.maximum(supplied, self._energy_input))
        self._energy_input = float(supplied[-1])
        moving = energy[:, 0] + energy[:, 1]
        bad = np.flatnonzero(moving > self.energy_guard * supplied + 1e-300)
        if len(bad):
            i = int(bad[0])
            raise SimulationError(
                f"step {int(steps[i])} (t = {int(steps[i]) * self.dt:g} s): {ERRORS[5]}: "
                f"kinetic + strain energy {moving[i]:.4g} J exceeds {self.energy_guard:g} x "
                f"the {supplied[i]:.4g} J supplied; the run is unstable (too few particles per "
                "element, too large a time step, or an indefinite mass matrix)",
                5, int(steps[i]))

    def _check(self):
        code = int(self.err[None])
        if code == 0:
            return
        step, where = int(self.err_step[None]) + 1, int(self.err_where[None])
        if code == 6:
            msg = (f"step {step} (t = {step * self.dt:g} s): {ERRORS[code]} (thread "
                   f"{where // self.scatter_block} waited {TEAM_SPIN_LIMIT} spins): Taichi's "
                   f"pool ran the team on fewer threads than it has; use mode='parallel'")
            raise SimulationError(msg, code, step)
        if code == 4:
            msg = f"step {step} (t = {step * self.dt:g} s): {ERRORS[code]} at node {where}"
            raise SimulationError(msg, code, step, node=where)
        if self.dim == 1:
            lo, hi = self.origin[0], self.origin[0] + self.n_elements * self.h
            at = f"x = {float(self.x[where][0]):g}, grid [{lo:g}, {hi:g}]"
        else:
            x = ", ".join(f"{c:g}" for c in self.x[where].to_numpy())
            hi = ", ".join(f"{o + n * self.h:g}" for o, n in zip(self.origin, self.grid_elements))
            at = (f"x = ({x}), grid from ({', '.join(f'{o:g}' for o in self.origin)}) "
                  f"to ({hi})")
        msg = f"step {step} (t = {step * self.dt:g} s): particle {where} {ERRORS[code]} ({at})"

        if code == 2:
            msg += "; the run is unstable: check the time step and the mass matrix"
        raise SimulationError(msg, code, step, particle=where)

    # ---- results -----------------------------------------------------------------------
    def project(self):
        """Nodal mass and momentum projected from the particles now (P2G alone).

        For inspection and tests; it overwrites the grid, so call it between steps only.
        """
        self._project_kernel()
        out = self.gm.to_numpy(), self._component(self.gp)
        if self.apic:
            self._clear_kernel()  # the affine step expects a cleared grid
        return out

    def positions(self) -> np.ndarray:
        return self._component(self.x)

    def displacements(self) -> np.ndarray:
        return self._component(self.u)

    def displacement_field(self, x) -> np.ndarray:
        """u_h(x) = sum_i phi_i(x) u_i at points x from the accumulated nodal displacements."""
        if not self.grid_displacement:
            raise RuntimeError("build the solver with grid_displacement=True")
        from .basis import evaluate

        phi, _ = evaluate(self.basis, (np.asarray(x, dtype=float) - self.origin[0]) * self.inv_h,
                          self.n_elements)
        return phi @ self._component(self.gu)

    def velocities(self) -> np.ndarray:
        return self._component(self.v)

    def _inertia(self):
        """D_p = sum_i phi_i (x_i - x_p)(x_i - x_p)^T of every particle (diagonal), (n, dim)."""
        from .basis import stencils

        x = self._component(self.x).reshape(self.n_particles, self.dim)
        out = np.empty_like(x)
        for k in range(self.dim):
            xi = (x[:, k] - self.origin[k]) * self.inv_h
            base, w, _ = stencils(self.basis, xi, self.grid_elements[k])
            r = (base[:, None] + np.arange(self.basis.support) - self.node_offset - xi[:, None])
            out[:, k] = np.sum(w * (r * self.h) ** 2, axis=1)
        return out

    def affine(self) -> np.ndarray:
        """The affine velocity C_p = B_p D_p^-1 of the APIC transfers, (n, dim, dim)."""
        if not self.apic:
            raise RuntimeError(f"the {self.transfer} transfer keeps no affine velocity")
        C = self.C.to_numpy()
        if self.basis.support == 2:  # the linear basis stores B_p
            C = C / self._inertia()[:, None, :]
        return C

    def set_affine(self, C):
        """Set the affine velocity C_p of every particle ((n, dim, dim) or one matrix)."""
        if not self.apic:
            raise RuntimeError(f"the {self.transfer} transfer keeps no affine velocity")
        C = np.broadcast_to(np.asarray(C, dtype=np.float64),
                            (self.n_particles, self.dim, self.dim)).copy()
        if self.basis.support == 2:
            C = C * self._inertia()[:, None, :]
        self.C.from_numpy(C)

    def stresses(self) -> np.ndarray:
        """Cauchy stress: one value per particle in 1D, else (n, dim, dim)."""
        return self._tensor(self.sigma.to_numpy())

    def strains(self) -> np.ndarray:
        """Accumulated (logarithmic) strain, sum of the increments d_eps."""
        return self._tensor(self.eps.to_numpy())

    def volumes(self) -> np.ndarray:
        """Particle volumes: V_p, or J V0 where the materials keep V0 and a J (JFluid)."""
        vol = self.vol.to_numpy()
        if not self.update_volume and "J" in self.needs:
            vol = vol * self.J.to_numpy()
        return vol

    def densities(self) -> np.ndarray:
        return self.m.to_numpy() / self.volumes()

    def grid_crossings(self) -> int:
        if not self.track_crossings:
            raise RuntimeError("this solver was built with track_crossings=False")
        return int(self.crossings[None])

    def negative_pivots(self) -> int:
        """Steps x nodes at which the consistent mass matrix had a negative pivot."""
        return int(self.neg_pivots[None])

    def energies(self) -> dict:
        """Recorded energies over time: kinetic, strain, gravity (potential), external work
        and total = kinetic + strain + gravity - external work."""
        if not self.record_energies:
            raise RuntimeError("this solver was built with energies=False")
        e = self._series("energy")
        gravity = e[:, 2] if self.has_u else e[:, 2] - e[0, 2]  # 2D/3D: -m g . (x - x0)
        out = {"t": self._series("t"), "kinetic": e[:, 0], "strain": e[:, 1],
               "gravity": gravity, "external_work": e[:, 3]}
        out["total"] = out["kinetic"] + out["strain"] + out["gravity"] - out["external_work"]
        return out

    def tracked(self) -> dict:
        """Recorded time series of the tracked particles: arrays of shape (records, tracked)."""
        out = {"t": self._series("t")}
        for key in ("x", "u", "v"):
            a = self._series(key, np.zeros((0, 0, self.dim)))
            out[key] = a[..., 0] if self.dim == 1 else a
        out["stress"] = self._tensor(self._series("stress", np.zeros((0, 0, 1))))
        return out

    def _series(self, key, empty=None):
        """The records of ``key`` as one array (``self.history`` holds one per drain)."""
        chunks = self.history.get(key)
        if not chunks:
            return np.zeros(0) if empty is None else empty
        return np.concatenate(chunks)

    def _tensor(self, a):
        # Taichi returns a 1x1 matrix field as (..., 1): one value per entry in 1D
        return a[..., 0] if self.dim == 1 else a

    def _component(self, fld):
        self._require_fields()
        a = fld.to_numpy()
        return a[:, 0] if self.dim == 1 else a


def _field_bytes(f) -> int:
    """Bytes one entry of a scalar, vector or matrix field holds."""
    if isinstance(f, ti.MatrixField):
        count = f.n * f.m
    else:
        count = 1
    return count * (8 if f.dtype in (ti.f64, ti.i64, ti.u64) else 4)


class _Progress:
    """A one-line progress bar on stderr for runs longer than a couple of seconds."""

    def __init__(self, total, enabled):
        self.total, self.enabled = max(int(total), 1), enabled
        self.start = time.perf_counter()
        self.shown = False

    def suggested_chunk(self, done):
        # small first chunks let the bar appear; later chunks cover about half a second
        if self.enabled is False:
            return self.total
        elapsed = time.perf_counter() - self.start
        if done == 0 or elapsed <= 0:
            return max(1, min(self.total, 2000))
        return max(1, int(done / elapsed * 0.5))

    def update(self, done):
        if self.enabled is False:
            return
        elapsed = time.perf_counter() - self.start
        if self.enabled is None and (elapsed < 2.0 or not sys.stderr.isatty()):
            return
        frac = done / self.total
        eta = elapsed / max(frac, 1e-12) - elapsed
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r[{bar:<30}] {100 * frac:5.1f}%  {elapsed:6.1f} s  eta {eta:6.1f} s")
        sys.stderr.flush()
        self.shown = True

    def close(self):
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()
