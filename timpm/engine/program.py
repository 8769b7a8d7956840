"""The compiled step program of one feature set, its fields allocated at a capacity.

A :class:`Program` is compiled once per :class:`~timpm.engine.features.FeatureSet` per
process (and loaded from Taichi's offline cache across processes): its fields hold up to
a capacity of particles, nodes and records (:mod:`.program_cache`), the live sizes and
every other scene value are run-time values (:mod:`.params`).  Scenes of one feature set
take turns in the same fields: a solver *activates* its state (uploads it) before it runs
or reads, and the state it replaces is saved to host memory first.

The step is the transfer scheme's list of phases (:mod:`.schemes`); the operations those
phases call come from the mixins, one unit each, listed lowest first in the class's bases:
the error record, the stencil, the scatter strategies, the phase runner, the grid's nodes
(boundary conditions, lumped solve), the consistent mass (1D banded, 2D/3D conjugate
gradients), the MLS projection, the grid solve, the particle update, the Runge-Kutta and
midpoint integrators, the uploads, recording, the drivers (fused serial, parallel,
team) and the state's way between host and kernels (:mod:`.host_state`).  A unit calls
only the units before it (``tests/test_layers.py``).
"""
import weakref

import taichi as ti

from .consistent_mass import ConsistentMass
from .consistent_mass_cg import ConsistentMassCG, cg_fields, cg_particle_fields
from .drivers import Drivers
from .failures import Failures
from .grid import NODE_NAMES, GridNodes, GridSolve
from .host_state import HostState
from .mls_projection import GAUSS_POINTS, MLSProjection
from .mls_stress_nd import MLSStressND, mls_nd_fields
from .params import ParamBlock
from .recorder import Recorder
from .midpoint import Midpoint, midpoint_fields
from .rk4 import RungeKutta, rk4_fields
from ..schemes import scheme_for
from .phase_runner import PhaseRunner
from .scatter import ScatterOps
from .stencil import StencilOps
from .transfer import Transfer
from .uploads import Uploads
from .views import FieldView, MaterialState

__all__ = ["Program"]


def _param_spec(features, scheme):
    d = features.dim
    spec = {"n_particles": "int", "elements": ("int", d), "nodes": ("int", d),
            "node_count": "int", "nodes_per_thread": "int", "scatter_block": "int",
            "n_tracked": "int", "h": "real", "inv_h": "real", "dt": "real",
            "origin": ("real", d), "gravity": ("real", d), "damping": "real",
            "mass_tol": "real", "pivot_tol": "real"}
    if features.mls_mpm:
        spec.update(D_inv="real", dt_D_inv="real")
    if features.volume_guard:
        spec.update(volume_min="real", volume_max="real")
    spec.update(scheme.PARAMS)  # the scheme's own run-time values
    if features.midpoint:
        spec.update(midpoint_relaxation="real")
    if features.traction is not None:
        spec.update(traction_particle="int", traction_amplitude="real", traction_param="real")
    if features.prescribed is not None:
        spec.update(prescribed_param="real")
    if features.surface_force is not None:
        spec.update(surface_param="real")
    if features.has_walls:
        spec.update(wall_mu=("real", 2 * d), wall_nodes=("int", 2 * d))
        if "driven" in features.walls:
            spec.update(wall_velocity=("real", 2 * d * d))
    groups = {"p": spec}
    for k, (cls, _) in enumerate(features.materials):
        groups[f"m{k}"] = {name: "real" for name in cls.CONSTANTS}
    return groups


#: the scratch the grid view carries beside the nodes: the 1D consistent mass's band and
#: its rows' flags, the MLS projections' sums at the Gauss points (1D and 2D) and the nodes,
#: the 1D body's extent
GRID_SCRATCH = ("band", "inactive", "g_mom", "g_sig", "g_rho", "n_mom", "n_vel", "body",
                "q_mom", "q_sig")


@ti.data_oriented
class Program(Failures, StencilOps, ScatterOps, PhaseRunner, GridNodes, ConsistentMass,
              ConsistentMassCG, MLSProjection, MLSStressND, GridSolve, Transfer, RungeKutta,
              Midpoint, Uploads, Recorder, Drivers, HostState):
    """Fields and kernels of one feature set at one capacity."""

    def __init__(self, features, capacity):
        f = self.f = features
        self.capacity = capacity
        # compile-time choices the phases read (through ti.static)
        self.dim, self.basis = f.dim, f.basis
        # the stencil's rows: every axis but the last (stencil.py)
        self.stencil_rows = self.basis.support ** (self.dim - 1)
        self.transfer, self.mode, self.team = f.transfer, f.mode, f.team
        self.on_device = f.on_device
        self.affine, self.mls_mpm, self.strain_remap = f.affine, f.mls_mpm, f.strain_remap
        self.consistent, self.mls, self.damping = f.consistent, f.mls, f.damping
        self.mls_study, self.mls_order = f.mls_study, f.mls_stress_order
        self.private_scatter, self.serial_scatter = f.private_scatter, f.serial_scatter
        self.run_sums, self.n_copies = f.run_sums, f.n_copies
        self.walls, self.has_walls = f.walls, f.has_walls
        self.has_traction, self.traction_fn = f.traction is not None, f.traction
        self.body_force = f.body_force
        self.prescribed, self.prescribed_fn = f.prescribed is not None, f.prescribed
        self.surface_force, self.surface_fn = f.surface_force is not None, f.surface_force
        self.external_work = self.has_traction or self.body_force or self.surface_force
        self.has_u, self.grid_displacement = f.has_u, f.grid_displacement
        self.track_crossings, self.tracking = f.track_crossings, f.tracking
        self.recording, self.record_energies = f.recording, f.energies
        self.needs, self.multi_material = f.needs, f.multi_material
        self.update_volume, self.rk4, self.midpoint = f.update_volume, f.rk4, f.midpoint
        # the strain energy: W(F) V0 of a hyperelastic law, else the work sigma : d_eps V
        # integrated along the path (a field only where some material needs it)
        self.path_work = f.energies and not all(cls.has_energy_function(flags)
                                                 for cls, flags in f.materials)
        self.bandwidth, self.node_offset = f.bandwidth, f.node_offset
        # the transfer scheme and its step as a list of phases (schemes/)
        self.scheme = scheme_for(f)
        self.phases = self.scheme.phases()
        # a team's node phase sums the copies of the scatter before it (drivers.py)
        self.merged_before = tuple(
            before.merge if k > 0 and before.kind == "scatter" else ()
            for k, before in enumerate((None,) + self.phases[:-1]))
        self._allocate(capacity)
        self._bind_kernels()
        self._active = None  # weak reference to the solver whose state the fields hold
        self.compiled = set()  # the kernels that ran once (compiled)

    # ---- fields ------------------------------------------------------------------------
    def _place(self, fb, axes, shape, fields):
        """Per-particle fields on one dense layout: together per particle on the CPU (one
        or two cache lines a particle), each its own array on a GPU (FeatureSet.on_device:
        a warp's 32 threads read 32 neighbouring values in one transaction)."""
        if self.on_device:
            for one in fields.values():
                fb.dense(axes, shape).place(one)
        else:
            fb.dense(axes, shape).place(*fields.values())

    def _allocate(self, cap):
        d, n = self.dim, cap.particles
        fb = ti.FieldsBuilder()
        real = float  # Taichi's default_fp: timpm.init(precision=...)
        block = ParamBlock(_param_spec(self.f, self.scheme), real, fb)
        self.params = block
        self.values = block.groups["p"]  # the run-time values: self.values.dt()
        # the compiled unit of each material, reading its constants from its group
        self.material_units = [cls.unit(flags, block.groups[f"m{k}"])
                               for k, (cls, flags) in enumerate(self.f.materials)]
        particle = {"x": ti.Vector.field(d, real), "v": ti.Vector.field(d, real),
                    "m": ti.field(real), "vol": ti.field(real),
                    "sigma": ti.Matrix.field(d, d, real)}
        # state only where a feature of the scene needs it
        if self.has_u:
            particle["u"] = ti.Vector.field(d, real)  # displacement (1D analytic solutions)
        if "eps" in self.needs:
            particle["eps"] = ti.Matrix.field(d, d, real)  # accumulated strain (1D law)
        if "F" in self.needs:
            particle["F"] = ti.Matrix.field(d, d, real)  # (elastic) deformation gradient
        if "J" in self.needs:
            particle["J"] = ti.field(real)  # volume ratio by its linearised rate (JFluid)
        if "ezz" in self.needs and d == 2:
            particle["ezz"] = ti.field(real)  # out-of-plane elastic log strain (plane strain)
        if "plastic" in self.needs:
            particle["plastic"] = ti.field(real)  # accumulated plastic strain
        if self.body_force:
            particle["b"] = ti.Vector.field(d, real)  # body force per unit mass b(X, t)
        if self.surface_force:
            particle["f_ext"] = ti.Vector.field(d, real)  # force (of tractions) times f(t)
        if self.affine:
            # affine velocity C_p of the APIC transfers (B_p = C_p D_p for the linear basis)
            particle["C"] = ti.Matrix.field(d, d, real)
        if self.multi_material:
            particle["mat"] = ti.field(ti.i32)
        if self.path_work:
            particle["work"] = ti.field(real)  # strain energy, integrated along the path
        if self.track_crossings:
            particle["elem"] = ti.Vector.field(d, ti.i32)
        self._place(fb, ti.i, n, particle)
        self.particle_fields = particle
        # grid: mass, momentum then velocity, force then acceleration (the affine transfer
        # folds the force into the momentum), Dirichlet mask (1D)
        grid = {"gm": ti.field(real), "gp": ti.Vector.field(d, real)}
        if not self.affine or self.midpoint:  # (the affine midpoint: its forces)
            grid["gf"] = ti.Vector.field(d, real)
        grid.update(self.scheme.grid_fields(d, real))  # the scheme's own
        if self.f.fixed:
            grid["fixed"] = ti.field(ti.i32)
        if self.prescribed:
            grid["fixed_v"] = ti.Vector.field(d, real)  # prescribed velocity (times f(t))
        if self.grid_displacement:
            grid["gu"] = ti.Vector.field(d, real)
        # (together per node on every backend: on an H200, mpm88's P2G at 1M particles took
        # 635 us so, 725 us with each grid field its own array, docs/performance.md)
        fb.dense(ti.axes(*range(d)), cap.nodes).place(*grid.values())
        self.grid_fields = grid
        # private scatter: thread k fills copy k of each scattered grid field (a leading
        # copy axis: no branch on the thread per add), summed into the grid afterwards
        self.copies = {}
        if self.private_scatter:
            for name in ["node_mass", "node_momentum"] + ([] if self.affine else ["node_force"]):
                self.copies[name] = (ti.field(real) if name == "node_mass"
                                     else ti.Vector.field(d, real))
            fb.dense(ti.axes(*range(d + 1)), (self.n_copies, *cap.nodes)).place(
                *self.copies.values())
        scratch = {}
        nn = cap.nodes[0]
        if self.consistent and d > 1:  # matrix-free conjugate gradients (consistent_mass_cg)
            fields = cg_fields(d, real)
            fb.dense(ti.axes(*range(d)), cap.nodes).place(*fields.values())
            scratch.update(fields)
            fields = cg_particle_fields(d, self.basis.support, real)
            fb.dense(ti.i, n).place(*fields.values())
            scratch.update(fields)
        elif self.consistent:
            scratch["band"] = ti.field(real)  # M[i, i + k - b] stored at band[i, k]
            scratch["inactive"] = ti.field(ti.i32)  # fixed or untouched rows of M
            fb.dense(ti.ij, (nn, 2 * self.bandwidth + 1)).place(scratch["band"])
            fb.dense(ti.i, nn).place(scratch["inactive"])
        if self.mls and d > 1:  # Gauss points per cell: 2 per axis (mls_stress_nd)
            fields = mls_nd_fields(d, self.mls_order, real)
            fb.dense(ti.axes(*range(d + 1)), (*cap.nodes, 2 ** d)).place(*fields.values())
            scratch.update(fields)
        elif self.mls:
            ng = len(GAUSS_POINTS)
            k = self.mls_order  # MLS sums: w d^0..2k, w rho_p d^0..1, w sigma_p d^0..k
            scratch.update(g_mom=ti.Vector.field(2 * k + 1, real), g_rho=ti.Vector.field(2, real),
                           g_sig=ti.Vector.field(k + 1, real))
            fb.dense(ti.ij, (nn, ng)).place(scratch["g_mom"], scratch["g_rho"], scratch["g_sig"])
            scratch["body"] = ti.Vector.field(2, real)  # the body: union of x_p -+ V_p / 2
            fb.place(scratch["body"])
            if self.mls_study:
                scratch.update(n_mom=ti.Vector.field(3, real), n_vel=ti.Vector.field(2, real))
                fb.dense(ti.i, nn).place(scratch["n_mom"], scratch["n_vel"])
        if self.rk4:  # the Runge-Kutta stages' scratch
            stages = rk4_fields(d, real, self.body_force)
            fb.dense(ti.i, n).place(*stages.values())
            scratch.update(stages)
            self.rk4_stages = FieldView("Runge-Kutta stage", stages)  # what rk4.py reads
        if self.midpoint:  # the midpoint iteration's scratch
            iterate = midpoint_fields(d, real, self.affine)
            fb.dense(ti.i, n).place(*iterate.values())
            self.midpoint_iterate = FieldView("midpoint iterate", iterate)  # midpoint.py's
            scratch.update(iterate)
        # run state and the first error
        run = {"step_count": ti.field(ti.i64), "time": ti.field(ti.f64),
               "crossings": ti.field(ti.i64), "err": ti.field(ti.i32),
               "err_count": ti.field(ti.i32), "err_step": ti.field(ti.i64),
               "err_where": ti.field(ti.i32), "neg_pivots": ti.field(ti.i64)}
        if self.external_work and self.record_energies:
            run["ext_work"] = ti.field(real)
        fb.place(*run.values())
        self.run_fields = run
        if self.team:
            scratch["team_arrived"] = ti.field(ti.i32)  # arrivals at the barriers of a launch
            scratch["team_abort"] = ti.field(ti.i32)
            scratch["rank_step"] = ti.field(ti.i64)  # the step each thread of the team is in
            fb.place(scratch["team_arrived"], scratch["team_abort"])
            fb.dense(ti.i, self.n_copies).place(scratch["rank_step"])
        history = {}
        if self.recording:
            cap_h = cap.history
            scratch["rec_count"] = ti.field(ti.i32)
            fb.place(scratch["rec_count"])
            history.update(t=ti.field(real), step=ti.field(ti.i64))
            fb.dense(ti.i, cap_h).place(history["t"], history["step"])
            if self.record_energies:
                # kinetic, strain, gravity, external
                history["energy"] = ti.Vector.field(4, real)
                fb.dense(ti.i, cap_h).place(history["energy"])
            if self.tracking:
                scratch["track_ids"] = ti.field(ti.i32)
                fb.dense(ti.i, cap.tracked).place(scratch["track_ids"])
                history.update(x=ti.Vector.field(d, real), v=ti.Vector.field(d, real),
                               stress=ti.Matrix.field(d, d, real))
                if self.has_u:
                    history["u"] = ti.Vector.field(d, real)
                fb.dense(ti.ij, (cap_h, cap.tracked)).place(
                    *(history[k] for k in ("x", "v", "stress", "u") if k in history))
        self.history_fields = history
        self.scratch_fields = scratch
        self._tree = fb.finalize()
        # the names the phases use
        for group in (particle, grid, scratch, run):
            for name, fld in group.items():
                setattr(self, name, fld)
        for name, key in NODE_NAMES.items():  # the grid as the kernels name it (grid.py)
            if key in grid:
                setattr(self, name, grid[key])
        # the state a scheme's phase receives (views.py)
        self.particles = FieldView("particle", particle)
        self.material_state = MaterialState(particle, self.dim, self.update_volume,
                                            self.accumulate)
        self.grid = FieldView("grid", {  # with the 1D consistent mass and MLS sums
            **{name: grid[key] for name, key in NODE_NAMES.items() if key in grid},
            **{name: scratch[name] for name in GRID_SCRATCH if name in scratch}})
        if history:
            self.h_t, self.h_step = history["t"], history["step"]
            for key, attr in (("energy", "h_energy"), ("x", "h_x"), ("v", "h_v"),
                              ("stress", "h_s"), ("u", "h_u")):
                if key in history:
                    setattr(self, attr, history[key])

    def all_fields(self):
        return [*self.particle_fields.values(), *self.grid_fields.values(),
                *self.copies.values(), *self.scratch_fields.values(),
                *self.run_fields.values(), *self.history_fields.values()]

    def release(self):
        if self._tree is not None:
            self._tree.destroy()
            self._tree = None

    # ---- kernels -----------------------------------------------------------------------
    def _bind_kernels(self):
        """The kernels as plain kernels closed over this program: a method kernel of a
        data-oriented class maps ``self`` to its compiled instance on every call, which
        doubled the launch (~27 against ~15 us, most of a small scene's step)."""
        if self.rk4 and self.mode != "serial":
            # the parallel Runge-Kutta step as launches: y_n kept, then a stage a launch
            # (its passes top-level loops; the stage compiled once, not unrolled four times)
            @ti.kernel
            def rk4_begin():
                self.rk4_begin(self.particles, self.rk4_stages, self.values)

            @ti.kernel
            def rk4_stage(s: ti.i32):
                self.rk4_stage(self.particles, self.grid, self.rk4_stages, self.values, s)
                if s == 3:
                    self.count_step()

            def step():
                rk4_begin()
                for s in range(4):
                    rk4_stage(s)
        else:
            @ti.kernel
            def step():
                self._one_step()

        @ti.kernel
        def record():
            self._one_task(self.record_step)

        @ti.kernel
        def advance(n_steps: ti.i32, every: ti.i32, record_first: ti.i32) -> ti.i32:
            done = 0
            ti.loop_config(serialize=True)
            for _ in range(1):  # one task on one thread: the fused serial mode
                if ti.static(self.recording):
                    if record_first:  # the state before the steps (no record kernel to build)
                        self.record_step()
                done = self.advance_steps(n_steps, every)
            return done

        @ti.kernel
        def project():
            self._one_task(self._clear_and_project)

        @ti.kernel
        def clear():
            self.clear_grid()

        self.step, self.record, self.advance = step, record, advance
        self.project, self.clear = project, clear
        self._bind_transfers()
        self._bind_history_reader()
        self._bind_uploads()
        if self.team:
            @ti.kernel
            def team(n_steps: ti.i32):
                self._team_steps(n_steps)

            self.team_steps = team

    def launch(self, n: int):
        """n steps of the parallel mode: one launch for a team, else one launch per step."""
        if self.team:
            self.team_steps(n)
        else:
            for _ in range(n):
                self.step()

    # ---- states taking turns -------------------------------------------------------------
    @property
    def active(self):
        return self._active() if self._active is not None else None

    def activate(self, owner):
        """Make the fields hold ``owner``'s state: the state there now is saved to its
        owner first, the fields are cleared and ``owner`` uploads its values and arrays
        (``owner.save_to_host(program)``, ``owner.load_into(program)``)."""
        current = self.active
        if current is owner:
            return False
        if current is not None:
            current.save_to_host(self)
        self._active = None
        owner.load_into(self)
        self._active = weakref.ref(owner)
        return True

    def deactivate(self, owner):
        """Forget ``owner`` (released): its state is not saved."""
        if self.active is owner:
            self._active = None
