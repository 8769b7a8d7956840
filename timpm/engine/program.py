"""The compiled step program of one feature set, its fields allocated at a capacity.

A :class:`Program` is compiled once per :class:`~timpm.engine.features.FeatureSet` per
process (and loaded from Taichi's offline cache across processes): its fields hold up to
a capacity of particles, nodes and records (:mod:`.program_cache`), the live sizes and
every other scene value are run-time values (:mod:`.params`).  Scenes of one feature set
take turns in the same fields: a solver *activates* its state (uploads it) before it runs
or reads, and the state it replaces is saved to host memory first.

The program allocates the union of what the scene's components declare they own (the
laws' particle state, the scheme's and the integrator's particle and grid fields and
parameters: :mod:`timpm.platform.declare`) beside the engine's own, and holds its units as
objects, each built from what it reads, lowest first: the failure record, the stencil,
the scatter, the boundary conditions, the consistent mass, the MLS projections, the grid's
clearing and mass solves, the loads, the laws, the shared G2P; the scheme (or integrator)
made with those operations; the recorder, the drivers that run the scheme's phases, the
uploads and the state's way between host and kernels (:mod:`.host_state`).
"""
import weakref
from types import SimpleNamespace

import taichi as ti

from ..platform.declare import Field
from ..schemes import INTEGRATORS, OPERATIONS, scheme_class, scheme_for
from ..schemes.phases import Whole
from .consistent_mass import BandedMass
from .consistent_mass_cg import CGMass, cg_fields, cg_particle_fields
from .drivers import Drivers
from .failures import Failures
from .g2p import G2P
from .grid import NODE_NAMES, Boundary, GridSolve
from .host_state import HostState
from .laws import Laws
from .loads import Loads
from .mls_projection import GAUSS_POINTS, MLSProjection
from .mls_stress_nd import MLSStressND, mls_nd_fields
from .params import ParamBlock
from .recorder import Recorder
from .scatter import Scatter, accumulate_in
from .stencil import Stencil
from .uploads import Uploads
from .views import FieldView, MaterialState
from .water import Pores
from .window import ActiveWindow, window_fields

__all__ = ["Program", "declared_fields"]


def _param_spec(features, scheme_cls):
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
    if features.water_level:
        spec.update(water_level="real")
    if features.drawdown:
        spec.update(final_level="real", drawdown_time="real")
    if features.drained_sides:
        spec.update(drained_nodes=("int", len(features.drained_sides)))
    if features.water_floor:
        spec.update(water_mass_floor="real")
    if features.has_side_pressure:
        spec.update(side_pressure_param="real")
    if features.phreatic:
        spec.update(phreatic_x=("real", features.phreatic),
                    phreatic_y=("real", features.phreatic))
    spec.update({name: param.kind for name, param in scheme_cls.PARAMS.items()})
    if features.midpoint:
        spec.update(midpoint_relaxation="real")
    if features.traction is not None:
        spec.update(traction_particle="int", traction_amplitude="real", traction_param="real")
    if features.prescribed is not None:
        spec.update(prescribed_param="real")
    if features.surface_force is not None:
        spec.update(surface_param="real")
    if features.planes:
        n_planes = len(features.planes)
        spec.update(plane_normal=("real", n_planes * d), plane_level=("real", n_planes),
                    plane_mu=("real", n_planes))
    if features.has_walls:
        spec.update(wall_mu=("real", 2 * d), wall_nodes=("int", 2 * d))
        if "driven" in features.walls:
            spec.update(wall_velocity=("real", 2 * d * d))
    groups = {"p": spec}
    for k, (cls, _) in enumerate(features.materials):
        groups[f"m{k}"] = {name: "real" for name in cls.CONSTANTS}
    return groups


#: the particle state every scene keeps
CORE_PARTICLE_FIELDS = {
    "x": Field("vector", doc="position"), "v": Field("vector", doc="velocity"),
    "m": Field(doc="mass"), "vol": Field(doc="volume"),
    "sigma": Field("matrix", doc="Cauchy stress")}


def declared_fields(features):
    """The particle fields of a feature set, name -> Field: every scene's, then the laws'
    (material-index order), the scheme's and the integrator's declarations, then the
    engine's own where a feature needs them.  A name declared twice must be declared
    alike (one field serves both)."""
    fields = dict(CORE_PARTICLE_FIELDS)
    if features.has_u:
        fields["u"] = Field("vector", doc="displacement (the 1D exact solutions)")
    if features.periodic:
        fields["laps"] = Field(doc="x periodic: the periods the particle has wrapped "
                                   "(+1 each time it left on the right), for its potential")

    def add(owner, declared):
        for name, fld in declared.items():
            if name in fields and (fields[name].shape, fields[name].dtype, fields[name].scratch) \
                    != (fld.shape, fld.dtype, fld.scratch):
                raise ValueError(f"{owner} declares the particle field {name!r} as {fld}, "
                                 f"which another component declares as {fields[name]}")
            fields.setdefault(name, fld)

    for cls, _ in features.materials:
        add(f"the {cls.name} law", cls.particle_fields(features.dim))
    if features.water is not None:
        add("the pore water", Pores.particle_fields(features))
    add("the transfer scheme", scheme_class(features).particle_fields(features))
    integrator = INTEGRATORS[features.integrator]
    if integrator is not None:
        add(f"the {features.integrator} integrator", integrator.particle_fields(features))
    engine = {}
    if features.body_force:
        engine["b"] = Field("vector", doc="body force per unit mass b(X, t)")
    if features.surface_force is not None:
        engine["f_ext"] = Field("vector", doc="force of the tractions, times f(t)")
    if features.multi_material:
        engine["mat"] = Field(dtype="int", doc="material index")
    if features.path_work:
        engine["work"] = Field(doc="strain energy, integrated along the path")
    if features.track_crossings:
        engine["elem"] = Field("vector", dtype="int", doc="element (grid crossings)")
    add("the engine", engine)
    return fields


def _taichi_field(fld: Field, dim, real):
    dtype = ti.i32 if fld.dtype == "int" else real
    entries = fld.entries(dim)
    if not entries:
        return ti.field(dtype)
    if len(entries) == 1:
        return ti.Vector.field(entries[0], dtype)
    return ti.Matrix.field(entries[0], entries[1], dtype)


#: the scratch the grid view carries beside the nodes: the 1D consistent mass's band and
#: its rows' flags, the MLS projections' sums at the Gauss points (1D and 2D) and the nodes,
#: the 1D body's extent
GRID_SCRATCH = ("band", "inactive", "g_mom", "g_sig", "g_rho", "n_mom", "n_vel", "body",
                "q_mom", "q_sig")


@ti.data_oriented
class Program:
    """Fields and kernels of one feature set at one capacity."""

    def __init__(self, features, capacity):
        self.f = features
        self.capacity = capacity
        self.dim, self.mode, self.team = features.dim, features.mode, features.team
        self.recording = features.recording
        self.scheme_class = scheme_class(features)
        self._allocate(capacity)
        self._build_units()
        self._bind_kernels()
        self._active = None  # weak reference to the solver whose state the fields hold
        self.compiled = set()  # the kernels that ran once (compiled)

    # ---- fields ------------------------------------------------------------------------
    def _place(self, fb, axes, shape, fields):
        """Per-particle fields on one dense layout: together per particle on the CPU (one
        or two cache lines a particle), each its own array on a GPU (FeatureSet.on_device:
        a warp's 32 threads read 32 neighbouring values in one transaction)."""
        if self.f.on_device:
            for one in fields.values():
                fb.dense(axes, shape).place(one)
        else:
            fb.dense(axes, shape).place(*fields.values())

    def _allocate(self, cap):
        f, d, n = self.f, self.f.dim, cap.particles
        fb = ti.FieldsBuilder()
        real = float  # Taichi's default_fp: timpm.init(precision=...)
        block = ParamBlock(_param_spec(f, self.scheme_class), real, fb)
        self.params = block
        self.values = block.groups["p"]  # the run-time values: self.values.dt()
        # particles: the state the components declare (laws, scheme, integrator) and the
        # engine's own; their per-step scratch apart (not saved with the state)
        declared = declared_fields(f)
        self.particle_declarations = {k: v for k, v in declared.items() if not v.scratch}
        particle = {name: _taichi_field(fld, d, real)
                    for name, fld in self.particle_declarations.items()}
        self._place(fb, ti.i, n, particle)
        self.particle_fields = particle
        stages = {name: _taichi_field(fld, d, real) for name, fld in declared.items()
                  if fld.scratch}
        if stages:
            fb.dense(ti.i, n).place(*stages.values())
        # grid: mass, momentum then velocity, and what the scheme and integrator declare
        # (the force then the acceleration, a new velocity ...); Dirichlet nodes, their
        # prescribed velocities, the nodal displacements (1D)
        grid = {"gm": ti.field(real), "gp": ti.Vector.field(d, real)}
        # the grid as the kernels name it: the engine's names, and those the scheme's own
        # fields declare; the fields P2G adds to (a copy each for the private scatter)
        names, scattered = dict(NODE_NAMES), {}
        integrator = INTEGRATORS[f.integrator]
        for owner in ((self.scheme_class,) + (() if integrator is None else (integrator,))
                      + ((Pores,) if f.water is not None else ())):
            for name, fld in owner.grid_fields(f).items():
                grid.setdefault(name, _taichi_field(fld, d, real))
                names.update({alias: name for alias in fld.names})
                if fld.scatter:
                    scattered[fld.names[0] if fld.names else
                              next(k for k, v in NODE_NAMES.items() if v == name)] = fld
        if f.fixed:
            grid["fixed"] = ti.field(ti.i32)
        if f.prescribed is not None:
            grid["fixed_v"] = ti.Vector.field(d, real)  # prescribed velocity (times f(t))
        if f.grid_displacement:
            grid["gu"] = ti.Vector.field(d, real)
        # (together per node on every backend: on an H200, mpm88's P2G at 1M particles took
        # 635 us so, 725 us with each grid field its own array, docs/performance.md)
        fb.dense(ti.axes(*range(d)), cap.nodes).place(*grid.values())
        self.grid_fields = grid
        # private scatter: thread k fills copy k of each scattered grid field (a leading
        # copy axis: no branch on the thread per add), summed into the grid afterwards
        self.copies = {}
        if f.private_scatter:
            for name in ["node_mass", "node_momentum"] + ([] if f.affine else ["node_force"]):
                self.copies[name] = (ti.field(real) if name == "node_mass"
                                     else ti.Vector.field(d, real))
            for name, fld in scattered.items():  # the scheme's own, as it declares them
                self.copies.setdefault(name, _taichi_field(fld, d, real))
            fb.dense(ti.axes(*range(d + 1)), (f.n_copies, *cap.nodes)).place(
                *self.copies.values())
        scratch = dict(stages)
        nn = cap.nodes[0]
        if f.consistent and d > 1:  # matrix-free conjugate gradients (consistent_mass_cg)
            fields = cg_fields(d, real)
            fb.dense(ti.axes(*range(d)), cap.nodes).place(*fields.values())
            scratch.update(fields)
            fields = cg_particle_fields(d, f.basis.support, real)
            fb.dense(ti.i, n).place(*fields.values())
            scratch.update(fields)
        elif f.consistent:
            scratch["band"] = ti.field(real)  # M[i, i + k - b] stored at band[i, k]
            scratch["inactive"] = ti.field(ti.i32)  # fixed or untouched rows of M
            fb.dense(ti.ij, (nn, 2 * f.bandwidth + 1)).place(scratch["band"])
            fb.dense(ti.i, nn).place(scratch["inactive"])
        if f.mls and d > 1:  # Gauss points per cell: 2 per axis (mls_stress_nd)
            fields = mls_nd_fields(d, f.mls_stress_order, real)
            fb.dense(ti.axes(*range(d + 1)), (*cap.nodes, 2 ** d)).place(*fields.values())
            scratch.update(fields)
        elif f.mls:
            ng = len(GAUSS_POINTS)
            k = f.mls_stress_order  # MLS sums: w d^0..2k, w rho_p d^0..1, w sigma_p d^0..k
            scratch.update(g_mom=ti.Vector.field(2 * k + 1, real), g_rho=ti.Vector.field(2, real),
                           g_sig=ti.Vector.field(k + 1, real))
            fb.dense(ti.ij, (nn, ng)).place(scratch["g_mom"], scratch["g_rho"], scratch["g_sig"])
            scratch["body"] = ti.Vector.field(2, real)  # the body: union of x_p -+ V_p / 2
            fb.place(scratch["body"])
            if f.mls_study:
                scratch.update(n_mom=ti.Vector.field(3, real), n_vel=ti.Vector.field(2, real))
                fb.dense(ti.i, nn).place(scratch["n_mom"], scratch["n_vel"])
        if f.grid_window:  # the active window's boxes and extent (window.py)
            fields = window_fields(real)
            fb.dense(ti.i, 4 * d).place(fields["window_box"])
            fb.dense(ti.i, 2 * d * f.n_copies).place(fields["window_extent"])
            scratch.update(fields)
        # run state and the first error
        run = {"step_count": ti.field(ti.i64), "time": ti.field(ti.f64),
               "crossings": ti.field(ti.i64), "err": ti.field(ti.i32),
               "err_count": ti.field(ti.i32), "err_step": ti.field(ti.i64),
               "err_where": ti.field(ti.i32), "neg_pivots": ti.field(ti.i64)}
        if f.energies and (f.traction is not None or f.body_force
                           or f.surface_force is not None or f.water_level):
            run["ext_work"] = ti.field(real)
        fb.place(*run.values())
        self.run_fields = run
        if f.team:
            scratch["team_arrived"] = ti.field(ti.i32)  # arrivals at the barriers of a launch
            scratch["team_abort"] = ti.field(ti.i32)
            scratch["rank_step"] = ti.field(ti.i64)  # the step each thread of the team is in
            fb.place(scratch["team_arrived"], scratch["team_abort"])
            fb.dense(ti.i, f.n_copies).place(scratch["rank_step"])
        history = {}
        if f.recording:
            cap_h = cap.history
            scratch["rec_count"] = ti.field(ti.i32)
            fb.place(scratch["rec_count"])
            history.update(t=ti.field(real), step=ti.field(ti.i64))
            fb.dense(ti.i, cap_h).place(history["t"], history["step"])
            if f.energies:
                # kinetic, strain, gravity, external
                history["energy"] = ti.Vector.field(4, real)
                fb.dense(ti.i, cap_h).place(history["energy"])
            if f.tracking:
                scratch["track_ids"] = ti.field(ti.i32)
                fb.dense(ti.i, cap.tracked).place(scratch["track_ids"])
                history.update(x=ti.Vector.field(d, real), v=ti.Vector.field(d, real),
                               stress=ti.Matrix.field(d, d, real))
                if f.has_u:
                    history["u"] = ti.Vector.field(d, real)
                fb.dense(ti.ij, (cap_h, cap.tracked)).place(
                    *(history[k] for k in ("x", "v", "stress", "u") if k in history))
        self.history_fields = history
        self.scratch_fields = scratch
        self._tree = fb.finalize()
        # the fields by name (Solver.read, the checkpoints, the failure report)
        for group in (particle, grid, scratch, run):
            for name, fld in group.items():
                setattr(self, name, fld)
        for name, key in names.items():  # the grid as the kernels name it (grid.py)
            if key in grid:
                setattr(self, name, grid[key])
        # the state the units and the scheme's phases receive (views.py): the particles
        # with their per-step scratch, the grid by the kernels' names with the consistent
        # mass's and the MLS projections' scratch
        self.particles = FieldView("particle", {**particle, **stages})
        self.grid = FieldView("grid", {
            **{name: grid[key] for name, key in names.items() if key in grid},
            **{name: grid[name] for name in ("fixed", "fixed_v") if name in grid},
            **{name: scratch[name] for name in GRID_SCRATCH if name in scratch}},
            storage=grid)
        self.run = FieldView("run", run)
        self.history = FieldView("history", history)

    def all_fields(self):
        return [*self.particle_fields.values(), *self.grid_fields.values(),
                *self.copies.values(), *self.scratch_fields.values(),
                *self.run_fields.values(), *self.history_fields.values()]

    def release(self):
        """Free the fields.  Taichi checks the fields made since its last kernel build at
        the next build, reading their trees: ``ti.sync`` runs that check now, while this
        tree stands (a program released before any of its kernels ran left the next build
        reading freed memory: an error naming a field, or a crash)."""
        if self._tree is not None:
            ti.sync()
            self._tree.destroy()
            self._tree = None

    # ---- units -----------------------------------------------------------------------
    def _build_units(self):
        """The units, each from what it reads, lowest first, and the scheme made with the
        operations they offer."""
        f, values, cap = self.f, self.values, self.capacity
        particles, grid, run, scratch = self.particles, self.grid, self.run, self.scratch_fields
        accumulate = accumulate_in(f.mode)
        team = FieldView("team", {k: scratch[k] for k in ("team_arrived", "team_abort",
                                                         "rank_step") if k in scratch})
        failures = Failures(f, run, scratch.get("rank_step"), values)
        stencil = Stencil(f, values)
        window = (ActiveWindow(f, values, scratch["window_box"], scratch["window_extent"])
                  if f.grid_window else None)
        scatter = Scatter(f, grid, self.copies, values, failures, cap.particles, window)
        boundary = Boundary(f, grid, run, values)
        banded = BandedMass(f, boundary, failures) if f.consistent and f.dim == 1 else None
        cg = (CGMass(f, stencil, boundary, failures, particles,
                     FieldView("conjugate-gradient", {k: v for k, v in scratch.items()
                                                      if k.startswith("cg_")}), values)
              if f.consistent and f.dim > 1 else None)
        mls = MLSProjection(f, accumulate, boundary) if f.mls and f.dim == 1 else None
        mls_nd = MLSStressND(f, stencil, accumulate) if f.mls and f.dim > 1 else None
        nodes = GridSolve(f, grid, values, boundary, stencil, accumulate, banded, cg, mls_nd,
                          window)
        pores = Pores(f, values, grid, accumulate, run)
        loads = Loads(f, run, accumulate, pores)
        # the compiled unit of each material, reading its constants from its group
        units = [cls.unit(flags, self.params.groups[f"m{k}"])
                 for k, (cls, flags) in enumerate(f.materials)]
        state = MaterialState(self.particles.fields, f.dim, f.update_volume, accumulate)
        laws = Laws(units, state, values)
        g2p = G2P(f, stencil, laws, loads, failures, run, accumulate, pores)
        self.ops = SimpleNamespace(stencil=stencil, scatter=scatter, boundary=boundary,
                                   nodes=nodes, banded=banded, cg=cg, mls=mls, mls_nd=mls_nd,
                                   loads=loads, g2p=g2p, laws=laws, failures=failures)
        assert set(vars(self.ops)) == set(OPERATIONS)
        # the transfer scheme (or the integrator that wraps it) and its step as phases
        self.scheme = scheme_for(f, self.ops)
        # the step: the active window first (where compiled in), the scheme's, the pores'
        first = (Whole("the active window: the box of nodes the particles reach",
                       window.find),) if window is not None else ()
        self.phases = first + self.scheme.phases() + pores.phases()
        buffer = FieldView("record", {k: scratch[k] for k in ("rec_count", "track_ids")
                                      if k in scratch})
        self.recorder = Recorder(f, particles, self.history, buffer, run, laws, accumulate,
                                 values)
        self.drivers = Drivers(f, self.phases, particles, grid, values, scatter, failures,
                               run, self.recorder, team, cap, window)
        self.uploads = Uploads(f, particles, laws, g2p, accumulate, values)
        self.host = HostState({"particle": self.particle_fields, "grid": self.grid_fields,
                               "copies": self.copies, "scratch": scratch,
                               "run": self.run_fields}, self.params, values,
                              self.drivers.node_of, scratch.get("rec_count"))
        self.read_history = self.recorder.read_history
        self.set_body_force, self.prestrain = self.uploads.set_body_force, self.uploads.prestrain

    # ---- kernels -----------------------------------------------------------------------
    def _bind_kernels(self):
        """The kernels as plain kernels closed over the units: a method kernel of a
        data-oriented class maps ``self`` to its compiled instance on every call, which
        doubled the launch (~27 against ~15 us, most of a small scene's step)."""
        drivers, recorder, scatter, nodes = (self.drivers, self.recorder, self.ops.scatter,
                                             self.ops.nodes)
        particles = self.particles
        groups = drivers.launch_groups()
        launches = []
        for k, group in enumerate(groups):
            launches.append(self._group_kernel(group, k == len(groups) - 1))

        if len(launches) == 1 and launches[0][1] == 1:  # one launch a step
            step = launches[0][2]
        else:
            def step():
                for launch, count, _ in launches:
                    for s in range(count):
                        launch(s)

        @ti.kernel
        def record():
            scatter.one_task(recorder.record_step)

        @ti.kernel
        def advance(n_steps: ti.i32, every: ti.i32, record_first: ti.i32) -> ti.i32:
            done = 0
            ti.loop_config(serialize=True)
            for _ in range(1):  # one task on one thread: the fused serial mode
                if ti.static(self.recording):
                    if record_first:  # the state before the steps (no record kernel to build)
                        recorder.record_step()
                done = drivers.advance_steps(n_steps, every)
            return done

        @ti.func
        def clear_and_project():
            nodes.project(particles)

        @ti.kernel
        def project():
            scatter.one_task(clear_and_project)

        @ti.kernel
        def clear():
            nodes.clear(True)

        self.step, self.record, self.advance = step, record, advance
        self.project, self.clear = project, clear
        if self.team:
            @ti.kernel
            def team(n_steps: ti.i32):
                drivers.team_steps(n_steps)

            self.team_steps = team

    def _group_kernel(self, group, last):
        """The launch of one group of the parallel step (``Drivers.launch_groups``): a
        function of the repetition s, how many times a step launches it, and its kernel
        (for a group launched once)."""
        drivers = self.drivers
        if isinstance(group, tuple):
            @ti.kernel
            def run_group():
                drivers.run_group(group, 0, last)

            return (lambda s: run_group()), 1, run_group

        @ti.kernel
        def run_repeat(s: ti.i32):
            drivers.run_group(group, s, last)

        return run_repeat, group.count, None

    @ti.func
    def advance_steps(self, n_steps, every):
        """The fused serial loop (a Batch inlines it in its own kernel)."""
        return self.drivers.advance_steps(n_steps, every)

    def launch(self, n: int):
        """n steps of the parallel mode: one launch for a team, else one launch per step."""
        if self.team:
            self.team_steps(n)
        else:
            for _ in range(n):
                self.step()

    # ---- the state between host and kernels (host_state.py) ---------------------------
    def state_layout(self):
        return self.host.state_layout()

    def host_arrays(self, n_particles, n_nodes):
        return self.host.host_arrays(n_particles, n_nodes)

    def load(self, arrays, track_ids):
        self.host.load(arrays, track_ids)

    def save(self, n_particles, n_nodes):
        return self.host.save(n_particles, n_nodes)

    def read(self, fld, count=None):
        return self.host.read(fld, count)

    def write(self, fld, values, count):
        self.host.write(fld, values, count)

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
