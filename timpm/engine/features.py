"""What a scene asks of the engine: the feature set (compile time) and the layout (run time).

:func:`plan` reads a :class:`~timpm.model.Model` (the one model of 1D to 3D, which a
:class:`~timpm.model.scene.Scene` or a :class:`~timpm.model.world.World` builds) and the solver's
options and splits them in two:

- a :class:`FeatureSet`, a frozen, hashable value of every compile-time choice (dimension,
  basis, transfer, mass, projection, materials, walls, loads, scatter, mode, what is
  recorded).  Programs are compiled and cached per feature set: scenes that share it
  share the compiled kernels, whatever their size;
- a :class:`Layout`: the sizes (particles, nodes, elements, tracked particles) and the
  run-time values (grid spacing, time step, gravity, loads, material constants).
"""
import math
from dataclasses import dataclass, field

import numpy as np

from ..model.model import Model
from ..model.walls import PLANE_TOLERANCE, SIDES
from ..platform import runtime
from ..schemes import INTEGRATORS, scheme_class
from ..schemes.two_phase import WATER_FILL_FLOOR

__all__ = ["FeatureSet", "Layout", "plan", "MODES", "GRIDS", "SCATTERS", "MIN_CPU_BLOCK",
           "auto_mode", "grid_window_refusal"]

MODES = ("auto", "serial", "parallel", "team")
#: the grid's node loops: over every node, or over the box of nodes the particles reach
#: this step and the last (engine/window.py); "auto" picks the window where the bodies
#: start in less than WINDOW_SHARE of the domain, it applies (grid_window_refusal) and
#: no team runs
GRIDS = ("auto", "dense", "window")
WINDOW_SHARE = 0.5
#: P2G scatter strategies: parallel atomic adds (the GPU path); the scatter loop on one
#: thread (plain adds); or one private grid copy per CPU thread, each filled with plain adds
#: by its share of the particles and summed into the grid afterwards.  "auto" picks
#: private on a multi-threaded CPU, serial on one thread and atomic on a GPU.
SCATTERS = ("auto", "atomic", "serial", "private")
#: Taichi's CPU range-for hands each thread one contiguous block of at least this many
#: iterations (pass make_cpu_multithreading_loop); shorter loops run on one thread
MIN_CPU_BLOCK = 512


def auto_mode(n_particles: int, serial_threshold: int, cpu_threads: int) -> str:
    """The mode ``mode="auto"`` picks: fused serial steps up to ``serial_threshold``
    particles, and at any size on one CPU thread (``cpu_threads``: 0 off the CPU), where a
    parallel loop only hands its work to Taichi's pool and waits to be woken (0.1-0.4 ms
    per step on a 2-vCPU machine, at any particle count); off the CPU, parallel launches
    (a serialized loop there runs on one GPU thread)."""
    if cpu_threads == 0:
        return "parallel"
    return "serial" if n_particles <= serial_threshold or cpu_threads == 1 else "parallel"


@dataclass(frozen=True)
class FeatureSet:
    """Every compile-time choice of a program.  Two scenes with equal feature sets run the
    same compiled kernels."""

    dim: int
    basis: type                  # the basis class (timpm.bases), compiled in
    transfer: str                # "musl", "apic" or "mls-mpm"
    consistent: bool             # consistent mass matrix (1D banded LU, 2D/3D CG)
    mls: bool                    # MLS projection of 4.4 (1D)
    materials: tuple             # ((material class, its flags()), ...) in material-index order
    walls: tuple | None          # wall kind per side ("open": none there, "driven": a moving
                                 # sticky wall); None: no walls
    periodic: bool               # x periodic: node index modulo the elements along x
    damping: bool                # local damping of A.4
    pic: bool                    # a PIC share in the MUSL velocity update (pic_fraction)
    traction: type | None        # time-function class of the particle traction (1D)
    body_force: bool             # a body force b(X, t) per particle, uploaded every step
    surface_force: type | None   # time-function class of the particle forces (tractions)
    fixed: bool                  # Dirichlet nodes
    prescribed: type | None      # time-function class of non-zero prescribed node velocities
    gravity: tuple               # per axis: a non-zero gravity
    has_u: bool                  # particle displacements (1D)
    grid_displacement: bool      # nodal displacements u_i += v_i dt
    track_crossings: bool
    energies: bool
    tracking: bool               # time series of tracked particles
    mode: str                    # "serial" (fused, one thread) or "parallel"
    scatter: str                 # "atomic", "serial" or "private"
    n_copies: int                # grid copies of the private scatter (1 otherwise)
    team: bool
    volume_guard: bool           # V / V0 checked against a range every step
    integrator: str              # "euler-cromer" (the study's), "rk4" or "midpoint"
    precision: str
    arch: str
    water: str | None = None     # the pore water's analysis (model/water.py): "drained",
                                 # "undrained", "coupled"; None: a dry scene
    water_level: bool = False    # a still-water level: buoyancy below it
    seepage: str = "none"        # "parallel": the pore water's force only along y (Water)
    phreatic: int = 0            # vertices of a phreatic surface (Water.phreatic), 0: none
    pore_smoothing: bool = False  # the pore strain's cell mean drives p_e (Water.smoothing)
    drawdown: bool = False       # the still-water level moves in time (Water.final_level)
    drained_sides: tuple = ()    # side indices (SIDES) the pore water flows through
    side_pressure: type | None = None  # time-function class of the drained sides'
                                 # prescribed pore pressures (Water.side_pressure); None: none
    water_floor: bool = False    # coupled on a kinked basis: the water's mass floored
    grid_window: bool = False    # node loops over the particles' active window (window.py)
    planes: tuple = ()           # per plane wall (model/walls.py: Plane) its (kind, drained);
                                 # its point, normal and mu are run-time values

    @property
    def pore_pressure(self) -> bool:
        """The particles keep an excess pore pressure (undrained and coupled analyses)."""
        return self.water in ("undrained", "coupled")

    @property
    def coupled(self) -> bool:
        """The single-point two-phase step (schemes/two_phase.py)."""
        return self.water == "coupled"

    # ---- derived choices ---------------------------------------------------------------
    @property
    def affine(self) -> bool:
        """An affine transfer (its scheme says so: APIC, MLS-MPM and their variants carry an
        affine velocity C_p and fold the forces into the momentum)."""
        return scheme_class(self).affine

    @property
    def mls_mpm(self) -> bool:
        return self.transfer == "mls-mpm"

    @property
    def mls_study(self) -> bool:
        """The MLS projection as the study has it (4.4, linear basis, lumped mass): mass,
        gravity and forces at the Gauss points from the reconstructed density and stress,
        nodal velocities by MLS.  Any other basis or mass takes only the stress from the
        Gauss points (the internal force); mass and momentum come from the particles."""
        return self.mls and self.basis.support == 2 and not self.consistent

    @property
    def mls_stress_order(self) -> int:
        """The polynomial order of the MLS stress reconstruction: 1 with the linear basis
        (4.4), 2 with the higher-order ones (their force integrand is of higher degree)."""
        return 1 if self.basis.support == 2 else 2

    @property
    def strain_remap(self) -> bool:
        """APIC with the linear basis takes the strain increment from the remapped velocity
        P'_i / m_i, P'_i = sum_p m_p phi_i v_p (the study's MUSL remap, 2.2.4): the grid
        velocity of a node a particle barely touches ~ 1 / phi and grad phi does not vanish
        with phi, so sum_i v_i grad phi_i^T is unbounded there (v_p and C_p are not)."""
        return self.transfer == "apic" and self.basis.support == 2

    @property
    def rk4(self) -> bool:
        """The classical Runge-Kutta method on the particles' equations (``.rk4``)."""
        return self.integrator == "rk4"

    @property
    def midpoint(self) -> bool:
        """The energy-conserving midpoint iteration (``.midpoint``)."""
        return self.integrator == "midpoint"

    @property
    def needs(self) -> frozenset:
        """The particle state the laws and the integrator keep (the names of their declared
        particle fields, scratch aside): F for every law under rk4 and midpoint."""
        names = set()
        for cls, _ in self.materials:
            names |= set(cls.particle_fields(self.dim))
        integrator = INTEGRATORS[self.integrator]
        if integrator is not None:
            names |= {name for name, fld in integrator.particle_fields(self).items()
                      if not fld.scratch}
        return frozenset(names)

    @property
    def path_work(self) -> bool:
        """The strain energy is the work sigma : d_eps V integrated along the path (a field
        of it) for some law: one without a stored energy W(F)."""
        return self.energies and not all(cls.has_energy_function(flags)
                                         for cls, flags in self.materials)

    @property
    def multi_material(self) -> bool:
        return len(self.materials) > 1

    @property
    def update_volume(self) -> bool:
        """V_p = det(F) V0, unless every material's stress acts on the initial volume."""
        return not all(cls.initial_volume for cls, _ in self.materials)

    @property
    def has_walls(self) -> bool:
        """Walls on the box's sides."""
        return self.walls is not None

    @property
    def walled(self) -> bool:
        """Walls on the box's sides or plane walls: some node's velocity is projected."""
        return self.walls is not None or bool(self.planes)

    @property
    def has_planes(self) -> bool:
        """Plane walls (model/walls.py: Plane)."""
        return bool(self.planes)

    @property
    def has_drained_planes(self) -> bool:
        """Plane walls the pore water flows through (Plane.drained)."""
        return any(drained for _, drained in self.planes)

    @property
    def has_traction(self) -> bool:
        """The study's particle traction (1D)."""
        return self.traction is not None

    @property
    def has_surface_force(self) -> bool:
        """Surface tractions spread over a face's particles."""
        return self.surface_force is not None

    @property
    def has_side_pressure(self) -> bool:
        """Prescribed pore pressures on drained sides (coupled: Water.side_pressure)."""
        return self.side_pressure is not None

    @property
    def has_prescribed(self) -> bool:
        """Dirichlet nodes (or walls) moving at a prescribed velocity."""
        return self.prescribed is not None

    @property
    def recording(self) -> bool:
        return self.energies or self.tracking

    @property
    def on_device(self) -> bool:
        """A GPU backend: each particle field its own array (a warp's loads coalesce), and
        the step's loops over the capacity (no serial task for bounds read from fields);
        the CPU keeps a particle's fields together and loops to the count."""
        return self.arch != "cpu"

    @property
    def private_scatter(self) -> bool:
        return self.n_copies > 1

    @property
    def serial_scatter(self) -> bool:
        """The scatter loop on one thread inside the parallel mode (the fused serial mode
        runs every loop on one thread anyway)."""
        return self.scatter == "serial" and self.mode == "parallel"

    @property
    def run_sums(self) -> bool:
        """1D on one thread (MUSL, lumped, standard projection): neighbouring particles
        share their element, so a run of them sums its node values in registers and adds
        them to the grid once (a store-to-load chain through the grid per particle
        otherwise)."""
        return (self.dim == 1 and not self.affine and not self.consistent and not self.mls
                and (self.mode == "serial" or self.serial_scatter))

    @property
    def bandwidth(self) -> int:
        return self.basis.support - 1

    @property
    def node_offset(self) -> int:
        basis = self.basis
        return basis.offset() if hasattr(basis, "offset") else 0


@dataclass
class Layout:
    """Sizes and run-time values of one scene under its feature set."""

    n_particles: int
    elements: tuple              # grid elements per axis
    nodes: tuple                 # grid nodes per axis
    n_tracked: int
    history: int                 # records the kernels hold between two reads
    room: tuple                  # grid nodes per axis the fields must hold (1D: + support)
    h: float                     # grid spacing
    origin: tuple                # position of the grid's first node (element 0)
    values: dict = field(default_factory=dict)          # the program's run-time values
    materials: list = field(default_factory=list)       # the material of each slot
    material_values: list = field(default_factory=list)  # its run-time constants
    fixed_nodes: list = field(default_factory=list)     # Dirichlet nodes (index tuples)
    fixed_velocity: object = None                       # their prescribed velocities


def _scatter_choice(scatter, mode, private_ok):
    if scatter not in SCATTERS:
        raise ValueError(f"unknown scatter {scatter!r}: choose one of {', '.join(SCATTERS)}")
    if scatter == "private" and not runtime.on_cpu():
        raise ValueError(f"the private scatter (a grid copy per CPU thread) runs on the CPU "
                         f"only, not on {runtime.arch()}: use scatter='atomic' (the default "
                         f"there)")
    if scatter == "private" and not private_ok:
        raise ValueError("the private scatter needs a lumped mass without the MLS "
                         "projection; use scatter='serial' or 'atomic'")
    if scatter == "auto":
        # a float atomic add is a compare-and-swap loop on the CPU, ~5x a plain add:
        # plain adds into a grid copy per thread there, atomics on GPUs
        if not runtime.on_cpu():
            return "atomic"
        if runtime.cpu_threads() > 1 and private_ok and mode == "parallel":
            return "private"
        return "serial"
    return scatter


def _volume_range(value):
    """``volume_range``: None (no guard) or (lowest, highest) V/V0, 0 < lowest < 1 <
    highest (highest may be infinite)."""
    if value is None:
        return None
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"volume_range must be None or (lowest, highest) V/V0, got "
                         f"{value!r}") from None
    if not (0.0 < lo < 1.0 < hi):  # NaN fails it too
        raise ValueError(f"volume_range must satisfy 0 < lowest < 1 < highest (V/V0), got "
                         f"{value!r}")
    return lo, hi


def grid_window_refusal(model, mode, on_cpu) -> str | None:
    """Why the active window (engine/window.py) does not apply to ``model`` run in ``mode``
    ("team" or another), or None where it does: its node loops must be the step's only
    ones and every scatter at the step's starting positions."""
    if model.dim == 1:
        return "a 1D grid (its loops are short; the banded mass and the MLS sums span it)"
    if model.integrator != "euler-cromer":
        return (f"the {model.integrator} integrator (its stages scatter from positions the "
                "step's start does not bound)")
    if model.mass_matrix == "consistent" or model.projection == "mls":
        return "the consistent mass and the MLS projection (their solves span the grid)"
    if model.periodic:
        return "a periodic x (the stencils wrap round)"
    if mode == "team":
        return "mode='team' (its threads split the whole grid's nodes)"
    if not on_cpu:
        return "a GPU (its loops run to the capacity)"
    return None


def _starting_share(model) -> float:
    """The share of the domain (between its walls, without the grid's padding) in the box
    of the particles' first positions, a cell wider."""
    x = np.asarray(model.positions, dtype=float).reshape(model.n_particles, model.dim)
    share = 1.0
    for k in range(model.dim):
        cells = (model.elements[k] if model.wall_cells is None
                 else model.wall_cells[k][1] - model.wall_cells[k][0])
        span = (x[:, k].max() - x[:, k].min()) / model.h + 1.0
        share *= min(1.0, span / cells)
    return float(share)


def plan(scene, track=(), energies=True, mode="auto", serial_threshold=4096,
         history_chunk=None, track_crossings=None, grid_displacement=False,
         small_mass=1e-3, scatter="auto", volume_range=(1e-2, 1e2), grid="auto"):
    """The feature set and layout of ``scene`` (a Model, or a Scene or World that builds
    one) run with the solver's options (checked)."""
    model = getattr(scene, "model", scene)
    if not isinstance(model, Model):
        raise TypeError(f"Solver takes a timpm.Scene (1D), a timpm.World (1D to 3D) or a "
                        f"timpm.model.Model, got {type(scene).__name__}")
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}: choose one of {', '.join(MODES)}")
    if grid not in GRIDS:
        raise ValueError(f"unknown grid {grid!r}: choose one of {', '.join(GRIDS)} (the node "
                         "loops over every node, or over the particles' active window)")
    volume_range = _volume_range(volume_range)
    n = model.n_particles
    for p in track:
        if not 0 <= p < n:
            raise ValueError(f"tracked particle {p} does not exist ({n} particles)")
    basis = model.basis
    dim, transfer = model.dim, model.transfer
    requested = mode
    on_cpu = runtime.on_cpu()
    threads = runtime.cpu_threads() if on_cpu else 0
    if model.integrator == "midpoint":  # its iteration runs each step on one thread
        if mode in ("parallel", "team"):
            raise ValueError(f"mode={mode!r}: the midpoint integrator iterates each step on "
                             "one thread; use mode='serial' or 'auto'")
        mode = "serial"
    if mode == "auto":
        mode = auto_mode(n, serial_threshold, threads)
    run_mode = "parallel" if mode == "team" else mode  # a team runs the parallel kernels
    consistent = model.mass_matrix == "consistent"
    mls = model.projection == "mls"
    scatter = _scatter_choice(scatter, run_mode, not (consistent or mls))
    # private: at least two copies, so that the path is the same on a one-core machine
    n_copies = max(2, threads) if scatter == "private" and run_mode == "parallel" else 1
    if n_copies > 1 and not runtime.static_cpu_blocks():
        raise ValueError("the private scatter relies on Taichi's static split of CPU "
                         "range-for loops (make_cpu_multithreading_loop), which is off")
    if grid_displacement and dim != 1:
        raise ValueError("grid_displacement is available for 1D scenes only")
    elements, origin, gravity = model.elements, model.origin, model.gravity
    materials, damping, traction = list(model.materials), model.damping, model.traction
    # a moving (sticky) wall is its own kind: the others compile as before
    walls = None if model.walls is None else tuple(
        "open" if w is None or w.kind == "periodic" else "driven" if w.moves else w.kind
        for w in model.walls)
    if walls is not None and all(w == "open" for w in walls):
        walls = None  # periodic x and no wall: nothing to apply at the nodes
    fixed_nodes = list(model.fixed_nodes)
    nodes = model.nodes
    strain_remap = transfer == "apic" and basis.support == 2
    private = n_copies > 1
    # team: the passes of many steps in one parallel task, each thread a fixed block of
    # particles (its own grid copy) and of nodes, the passes separated by spin barriers:
    # Taichi's pool is woken once per launch, not three to five times per step
    team_ok = (private and not strain_remap and model.integrator == "euler-cromer"
               and threads >= n_copies)
    # the active window: asked, or (auto) where the bodies start in a small part of the
    # domain, it applies and no team runs (a team splits the whole grid; its dense step
    # beat the windowed parallel one on the slope demo, 1.28 against 1.67 ms, and on
    # examples/large_slope.toml, 6.7 against 8.1 ms: the particles' work dominates there)
    team_auto = team_ok and requested in ("team", "auto")
    refusal = grid_window_refusal(model, requested if requested == "team" else run_mode,
                                  on_cpu)
    if grid == "window" and refusal is not None:
        raise ValueError(f"grid='window' does not apply to {refusal}: use grid='dense' or "
                         "'auto'")
    window = grid == "window" or bool(grid == "auto" and refusal is None and not team_auto
                                      and _starting_share(model) < WINDOW_SHARE)
    if window:
        team_ok = False
    if requested == "team" and not team_ok:
        raise ValueError("mode='team' needs the private scatter (lumped mass, standard "
                         "projection) with a thread per grid copy (two CPU threads or more); "
                         "APIC with the linear basis (its strain remap) and the rk4 "
                         "and midpoint integrators have no team")
    if grid_displacement and model.integrator != "euler-cromer":
        raise ValueError("grid_displacement accumulates v_i dt of the Euler-Cromer step: the "
                         f"{model.integrator} integrator has none")
    has_u = dim == 1  # particle displacements: the 1D exact solutions compare them
    crossings = (dim == 1) if track_crossings is None else bool(track_crossings)
    features = FeatureSet(
        dim=dim, basis=basis, transfer=transfer, consistent=consistent, mls=mls,
        materials=tuple((type(m), m.flags()) for m in materials), walls=walls,
        periodic=model.periodic,
        damping=damping > 0.0, pic=model.pic_fraction > 0.0,
        traction=None if traction is None else type(traction.time_function),
        body_force=model.body_force is not None,
        surface_force=(None if model.particle_force is None
                       else type(model.particle_force_time)),
        fixed=bool(fixed_nodes),
        prescribed=type(model.fixed_time) if model.prescribes_motion else None,
        gravity=tuple(g != 0.0 for g in gravity), has_u=has_u,
        grid_displacement=bool(grid_displacement), track_crossings=crossings,
        energies=bool(energies), tracking=len(track) > 0, mode=run_mode, scatter=scatter,
        n_copies=n_copies, team=team_ok and requested in ("team", "auto"),
        volume_guard=volume_range is not None and not all(m.initial_volume for m in materials),
        integrator=model.integrator,
        precision=runtime.precision(), arch=runtime.arch(),
        water=None if model.water is None else model.water.analysis,
        water_level=model.water is not None and model.water.highest is not None,
        seepage="none" if model.water is None else model.water.seepage,
        phreatic=0 if model.water is None or model.water.phreatic is None
        else len(model.water.phreatic),
        pore_smoothing=model.water is not None and model.water.smoothing == "cell",
        drawdown=model.water is not None and model.water.drawdown,
        drained_sides=() if model.water is None else tuple(
            SIDES.index(side) for side in model.water.drained_sides),
        side_pressure=(type(model.water.pressure_time) if model.water is not None
                       and model.water.pressured else None),
        water_floor=(model.water is not None and model.water.analysis == "coupled"
                     and basis.kinked),
        grid_window=window,
        planes=tuple((plane.kind, plane.drained) for plane in model.planes))
    if history_chunk is None:
        # records the kernels hold between two reads from Python: about 4 MiB
        per_tracked = 8 * (2 * dim + dim * dim + (dim if has_u else 0))
        record = 16 + 32 * bool(energies) + len(track) * per_tracked
        history_chunk = min(16384, max(512, (4 << 20) // record))
    h = model.h
    mass_scale = float(np.mean(model.mass_per_particle))
    values = dict(
        n_particles=n, elements=elements, nodes=nodes, h=h, inv_h=1.0 / h, dt=model.dt,
        origin=origin, gravity=gravity, damping=damping,
        # nodes with less mass than this are empty; the consistent mass drops nodes that a
        # particle barely touches (their rows make M ill-conditioned: the small-mass problem)
        mass_tol=(small_mass if consistent else 1e-14) * mass_scale,
        pivot_tol=1e-14 * mass_scale,
        scatter_block=max(MIN_CPU_BLOCK, -(-n // n_copies)), n_tracked=len(track))
    if features.volume_guard:
        values.update(volume_min=volume_range[0], volume_max=volume_range[1])
    for name in scheme_class(features).PARAMS:  # the transfer scheme's own values
        values[name] = model.transfer_params[name]
    if features.midpoint:
        # the relaxation of vbar that balances the pass's slow and fast modes for
        # mu = |w dt| / 2 up to dt / dt_crit (1 without an estimate; schemes/midpoint.py)
        critical = getattr(scene, "critical_dt", None)
        mu = model.dt / critical if critical else 1.0
        values.update(midpoint_relaxation=((math.sqrt(mu * mu + 4.0) - mu) / 2.0) ** 2)
    if features.water_level:  # the level, or the phreatic surface's top (a quick test)
        values.update(water_level=model.water.highest)
    if features.drawdown:
        values.update(final_level=model.water.final_level,
                      drawdown_time=model.water.drawdown_time)
    if features.drained_sides:  # per drained side its edge node (as a wall's, wall_nodes)
        edges = [i for pair in model.wall_nodes() for i in pair]
        values.update(drained_nodes=tuple(edges[side] for side in features.drained_sides))
    if features.water_floor:  # the least water a node's solve takes at face value
        values.update(water_mass_floor=WATER_FILL_FLOOR * h ** dim * float(
            np.max(model.water_arrays["rho_w"])))
    if features.has_side_pressure:  # (the nodal forces: a grid field, state.py)
        values.update(side_pressure_param=float(model.water.pressure_time.param))
    if features.phreatic:
        values.update(phreatic_x=tuple(x for x, _ in model.water.phreatic),
                      phreatic_y=tuple(y for _, y in model.water.phreatic))
    if features.mls_mpm:
        D_inv = 1.0 / (basis.inertia * h ** 2)
        values.update(D_inv=D_inv, dt_D_inv=model.dt * D_inv)
    if traction is not None:
        values.update(traction_particle=traction.particle,
                      traction_amplitude=float(traction.amplitude),
                      traction_param=float(traction.time_function.param))
    if model.particle_force is not None:
        values.update(surface_param=float(model.particle_force_time.param))
    if model.prescribes_motion:
        values.update(prescribed_param=float(model.fixed_time.param))
    if walls is not None:
        values.update(wall_mu=tuple(0.0 if w is None else w.mu for w in model.walls),
                      wall_nodes=tuple(i for pair in model.wall_nodes() for i in pair))
        if model.moving_walls:  # per side its velocity vector, zeros for the others
            values.update(wall_velocity=tuple(
                c for w in model.walls for c in (w.velocity if w is not None and w.moves
                                                 else (0.0,) * dim)))
    if features.planes:
        # per plane its unit normal n and its level (p - origin) . n / h - tolerance: a node
        # whose coordinates xi (in cells from the origin) have xi . n >= level is held
        # (Boundary.on_plane: (x_i - p) . n >= -PLANE_TOLERANCE h, Model.plane_nodes)
        values.update(
            plane_normal=tuple(c for plane in model.planes for c in plane.normal),
            plane_level=tuple(float(np.dot(np.subtract(plane.point, origin), plane.normal))
                              / h - PLANE_TOLERANCE for plane in model.planes),
            plane_mu=tuple(plane.mu for plane in model.planes))
    # 1D: room for a stencil beyond the last node (the banded solve reads it, as zeros)
    room = (nodes[0] + basis.support,) if dim == 1 else nodes
    layout = Layout(n_particles=n, elements=tuple(elements), nodes=nodes, room=room,
                    n_tracked=len(track), history=int(history_chunk), h=h,
                    origin=tuple(origin), values=values, materials=materials,
                    material_values=[m.constants(model.dt, model.h) for m in materials],
                    fixed_nodes=fixed_nodes, fixed_velocity=model.fixed_velocity)
    return features, layout
