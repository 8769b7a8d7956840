"""The one model of a simulation in 1, 2 or 3 dimensions: what the engine reads.

A :class:`Model` holds a uniform grid (origin, spacing, elements per axis) and a basis on
it, the particles (positions, velocities, volumes, the material of each), the materials,
the transfer and mass matrix, the loads (gravity, the study's particle traction) and the
boundaries: walls on the sides of a box (sticky, slip, Coulomb friction, or none), plane
walls at any angle (2D and 3D: :class:`~timpm.model.walls.Plane`) and Dirichlet nodes held
at rest.  Every value is checked on construction, each error naming what is wrong and
where.

Two builders make models: :class:`timpm.model.scene.Scene` (1D: a grid and particles placed in
its elements, the study's problems) and :class:`timpm.model.world.World` (a box domain in 1D,
2D or 3D filled with bodies).  Both take walls and Dirichlet nodes; the engine
(:func:`timpm.engine.features.plan`) reads only the model.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..bases import Basis, get_basis
from ..platform.checks import check_size, positive, positive_int, shown_point, vector
from ..platform.declare import check_params
from ..platform.errors import InputError, about
from ..schemes import TRANSFERS as SCHEME_TRANSFERS, scheme_classes, scheme_params
from .loads import BodyForce, field_function, time_function
from ..materials import Material
from .water import checked_water
from .walls import (PLANE_KINDS, SIDES, WALL_KINDS, Plane, Wall, checked_planes, plane_nodes,
                    walls_from)

__all__ = ["Model", "Wall", "Plane", "PLANE_KINDS", "walls_from", "check_scheme", "pic_applies",
           "with_pic_fraction", "SIDES", "WALL_KINDS",
           "ND_BASES", "TRANSFERS", "MASS_KINDS", "PROJECTIONS", "INTEGRATORS",
           "CRITICAL_STEP_FACTOR"]

#: bases on multi-dimensional grids (tensor products; B-splines of any degree N as
#: bsplineN, clamped, or uniform-bsplineN, padded); every basis works in 1D
ND_BASES = ("linear", "bspline2", "bspline3", "uniform-bspline2", "uniform-bspline3")
#: the transfers the schemes' registry runs (timpm.schemes: "musl", the study's scheme
#: (2.2.4) in any dimension; "apic", the affine transfer (Jiang et al. 2015); "mls-mpm",
#: APIC with the force and velocity gradient from the affine moments (Hu et al. 2018),
#: the cheapest (B-spline bases only); each scheme's file says what it takes)
TRANSFERS = SCHEME_TRANSFERS
MASS_KINDS = ("lumped", "consistent")
#: "standard": particles are the integration points (2.2.4); "mls": nodal velocities,
#: density and stress reconstructed by moving least squares, forces at Gauss points (4.4)
PROJECTIONS = ("standard", "mls")
#: time integration: "euler-cromer", the study's (2.2.4: v_p then x_p with the new
#: velocity); "rk4": the classical fourth-order Runge-Kutta method on the particles'
#: semi-discrete equations dx_p/dt = sum phi_i v_i, dv_p/dt = sum phi_i a_i, dF_p/dt =
#: (sum v_i grad phi_i^T) F_p (four grid solves a step), for laws whose stress is sigma(F);
#: "midpoint": the energy-conserving MUSL step at the mid-step velocity and averaged stress
#: (schemes/midpoint.py), iterated within each step, for the same laws
INTEGRATORS = ("euler-cromer", "rk4", "midpoint")
#: each integrator's critical time step relative to Euler-Cromer's 2 / w_max: the
#: stability limit of |w dt| on the imaginary axis, 2 for Euler-Cromer, 2 sqrt(2) for RK4;
#: midpoint keeps Euler-Cromer's (its relaxed passes converge beyond it, ever slower)
CRITICAL_STEP_FACTOR = {"euler-cromer": 1.0, "rk4": math.sqrt(2.0), "midpoint": 1.0}


def _integrators(transfer):
    """The integrators every scheme of ``transfer`` lets replace its step."""
    return set.intersection(*(set(cls.integrators) for cls in scheme_classes(transfer)))


def pic_applies(transfer="musl", mass="lumped", projection="standard") -> bool:
    """Whether a PIC share (``pic_fraction``) blends into this scheme's velocity update:
    the musl transfer's FLIP update with the lumped mass and the standard projection."""
    return ("pic_fraction" in scheme_params(transfer) and mass == "lumped"
            and projection == "standard")


def check_scheme(dim, basis, transfer="musl", mass="lumped", projection="standard",
                 damping=0.0, pic_fraction=None, transfer_params=None) -> dict:
    """The basis, transfer, mass matrix, projection and damping of a ``dim``-dimensional
    model go together (an error names the conflict); the transfer's parameters
    (``transfer_params``, checked against what its schemes declare, their defaults filled
    in) are returned.  ``pic_fraction`` is the musl transfer's ``transfer_params``
    entry of that name, given on its own."""
    with about("basis"):
        basis = get_basis(basis)
        if dim > 1 and not basis.nd:
            raise ValueError(f"the {basis.name} basis is 1D only: 2D/3D grids take "
                             f"{', '.join(ND_BASES)}")
    with about("transfer"):
        if transfer not in TRANSFERS:
            raise ValueError(f"unknown transfer {transfer!r}: choose one of "
                             f"{', '.join(TRANSFERS)}")
    with about("mass_matrix"):
        _check_mass(basis, mass)
    with about("projection"):
        _check_projection(dim, basis, projection)
    with about("damping"):
        given = damping
        try:
            damping = float(damping)
        except (TypeError, ValueError):
            damping = float("nan")
        if not (0.0 <= damping < 1.0):
            raise ValueError(f"damping factor alpha must lie in [0, 1), got {given!r}")
    declared = scheme_params(transfer)
    params = with_pic_fraction(transfer, pic_fraction, transfer_params)
    try:
        params = check_params(f"the {transfer} transfer", declared, params)
    except InputError as err:  # about the parameter: transfer_params.NAME
        raise InputError(str(err), "transfer_params" + (f".{err.key}" if err.key else "")) \
            from None
    with about("transfer"):
        for cls in scheme_classes(transfer):  # what each scheme of the transfer takes
            cls.check(transfer, dim, basis, mass, projection, damping, params)
    return params


def with_pic_fraction(transfer, pic_fraction, transfer_params):
    """``transfer_params`` with ``pic_fraction`` (the musl transfer's parameter of that name,
    given on its own by a builder: a Scene, a World, a problem, a scene file's key, the
    command line's --pic-fraction; None or 0: not given) among them, unchecked."""
    params = dict(transfer_params or {}) if isinstance(transfer_params, (dict, type(None))) \
        else transfer_params
    if pic_fraction is not None and pic_fraction != 0.0 and isinstance(params, dict):
        with about("pic_fraction"):
            if "pic_fraction" not in scheme_params(transfer) and transfer in TRANSFERS:
                raise ValueError(f"pic_fraction blends PIC into the musl transfer's FLIP "
                                 f"update with the lumped mass and the standard projection, "
                                 f"not {transfer} (apic and mls-mpm carry the velocity as PIC "
                                 "already)")
            if "pic_fraction" in params and params["pic_fraction"] != pic_fraction:
                raise ValueError(f"pic_fraction is given twice: {pic_fraction!r} and "
                                 f"transfer_params['pic_fraction'] = "
                                 f"{params['pic_fraction']!r}")
        params["pic_fraction"] = pic_fraction
    return params


def _check_mass(basis, mass):
    if mass not in MASS_KINDS:
        raise ValueError(f"unknown mass {mass!r}: choose one of {', '.join(MASS_KINDS)}")
    if mass == "lumped" and not basis.lumpable:
        raise ValueError(f"the {basis.name} basis takes negative values, so its mass matrix "
                         "cannot be lumped (study 5.1): use the consistent mass "
                         "(mass='consistent', --mass consistent)")


def _check_projection(dim, basis, projection):
    if projection not in PROJECTIONS:
        raise ValueError(f"unknown projection {projection!r}: choose one of "
                         f"{', '.join(PROJECTIONS)}")
    if projection == "mls" and dim == 3:
        raise ValueError("the MLS projection is implemented in 1D and 2D, not 3D")
    if projection == "mls" and dim == 2 and basis.support == 2:
        raise ValueError("in 2D the MLS projection reconstructs the stress only (Gauss-point "
                         f"forces): it takes a B-spline of degree 2 or more, not {basis.name}")


def _index_array(name, value, n, limit):
    a = np.asarray(value)
    if a.shape != (n,) or not (np.issubdtype(a.dtype, np.integer) or a.dtype == bool):
        raise ValueError(f"{name} must be {n} integers, got shape {a.shape} of {a.dtype}")
    if n and (a.min() < 0 or a.max() >= limit):
        raise ValueError(f"{name} must lie in 0..{limit - 1}, got {int(a.min())}..{int(a.max())}")
    return a.astype(np.int32)


@dataclass(frozen=True, eq=False)
class Model:
    """One simulation on a uniform grid in ``len(elements)`` dimensions (see the module).

    ``positions`` (n, dim) are absolute coordinates inside the grid [origin, origin +
    elements h]; ``volume`` the initial particle volumes; ``materials`` the material
    objects and ``material_index`` the one of each particle (default: all the first);
    ``walls`` one :class:`Wall` or None per side (``SIDES``), standing at ``wall_cells``
    (per axis the lower and upper wall position in cells from the grid origin; default the
    grid's ends); ``fixed_nodes`` grid nodes (index tuples) held at zero velocity, or a
    dict of node to prescribed velocity v (a number in 1D, a vector): the node moves at
    v f(t), f the time function ``fixed_time`` (default :class:`~timpm.model.loads.Constant`;
    lumped mass, standard projection);
    ``gravity`` the acceleration per axis; ``body_force`` a :class:`~timpm.model.loads.BodyForce`
    b(X, t) per unit mass (a Python function, vectorised); ``traction`` the study's load
    on one particle (1D); ``damping`` the local damping factor alpha of A.4;
    ``transfer_params`` the parameters of the transfer's scheme, name -> number (each
    scheme declares its own, with its range and default: ``timpm.schemes``; checked here,
    the defaults filled in): the musl transfer's ``pic_fraction`` b (``Model.pic_fraction``)
    blends the MUSL particle velocity update, v_p = (1 - b)(v_p + dt sum phi_i a_i) + b sum
    phi_i (v_i + dt a_i) (0: FLIP, the study's; 1: PIC, which damps the particle-velocity
    modes the grid cannot see); the builders take it on its own too.  ``integrator`` the
    time integration (``INTEGRATORS``; ``"rk4"`` and ``"midpoint"`` for laws whose stress is a function
    of F, with roller and sticky walls only, no damping, tractions or prescribed motion).
    ``velocity`` is an (n, dim) array or a function v0(X) of the (n, dim) positions.
    ``displacement`` a function u0(X) (vectorised like v0): the body starts deformed, its
    particles at x = X + u0(X) with F = I + grad u0 (central differences of u0, step
    1e-6 h), volumes det(F) V and the stresses of one material update from the
    undeformed state; ``positions`` and ``volume`` are then the reference X and V0.
    ``particle_force`` an (n, dim) array of forces on the particles (the surface tractions
    a World spreads over a face's particles), times the time function
    ``particle_force_time`` (default Constant).  ``initial_stress`` an (n, 3, 3) array of
    Cauchy stresses the particles start from (2D and 3D; in 2D entry [2, 2] is the
    out-of-plane stress of plane strain): each material sets its elastic strain from it
    (``Material.initial_state``: Drucker-Prager and Mohr-Coulomb), e.g. the geostatic
    stress of :mod:`timpm.model.geostatic`.  ``water`` the scene's
    :class:`~timpm.model.water.Water` (its analysis and still-water level) and
    ``pore_water`` one :class:`~timpm.materials.pore_water.PoreWater` or None per material
    (the saturated ones); ``initial_pore_pressure`` the (n,) excess pore pressures the
    particles start from (undrained and coupled analyses; default 0): the stress the grid
    sees starts at sigma' - p_e I, sigma' the initial stress (or zero).
    ``particle_values`` the initial values of law fields per particle, name -> (n, ...)
    array (a random field's strength, MohrCoulombField's ``strength``);
    ``pore_conductivity`` the (n,) hydraulic conductivities of the particles' pore water
    (a random field's; nan: the material's PoreWater's), a coupled analysis's drag.
    ``planes`` plane walls at any angle (:class:`~timpm.model.walls.Plane`, 2D and 3D):
    each holds the grid nodes on or beyond it (:meth:`plane_nodes`), every particle
    starting on its material side; a ``drained`` one lets a coupled analysis's pore water
    through.
    """

    basis: "str | type[Basis]"  # a name or a Basis class; the class once checked
    origin: tuple
    h: float
    elements: tuple
    positions: np.ndarray
    volume: np.ndarray
    materials: tuple
    dt: float
    velocity: np.ndarray | None = None
    displacement: object = None
    material_index: np.ndarray | None = None
    body_index: np.ndarray | None = None
    transfer: str = "musl"
    mass_matrix: str = "lumped"
    projection: str = "standard"
    gravity: tuple | None = None
    damping: float = 0.0
    transfer_params: dict | None = None
    integrator: str = "euler-cromer"
    walls: tuple | None = None
    wall_cells: tuple | None = None
    fixed_nodes: tuple = ()
    traction: object = None
    body_force: object = None
    fixed_time: object = None
    particle_force: object = None
    particle_force_time: object = None
    initial_stress: object = None
    water: object = None
    pore_water: tuple | None = None
    initial_pore_pressure: np.ndarray | None = None
    particle_values: dict | None = None
    pore_conductivity: object = None
    planes: tuple = ()
    name: str = "model"

    def __post_init__(self):
        # each check's error names the field it is about (InputError.key)
        set_ = lambda key, value: object.__setattr__(self, key, value)  # noqa: E731
        with about("elements"):
            elements = tuple(positive_int("number of elements", e) for e in
                             np.atleast_1d(np.asarray(self.elements, dtype=object)))
            dim = len(elements)
            if dim not in (1, 2, 3):
                raise ValueError(f"a model has 1, 2 or 3 dimensions, got {dim}")
        set_("elements", elements)
        with about("h"):
            set_("h", positive("element size h", self.h))
        with about("origin"):
            set_("origin", tuple(vector("grid origin", self.origin, dim)))
        with about("basis"):
            basis = get_basis(self.basis)
            set_("basis", basis)
            for k, e in enumerate(elements):
                if e < basis.min_elements:
                    raise ValueError(f"the {basis.name} basis needs at least "
                                     f"{basis.min_elements} elements, the grid has {e}"
                                     + (f" along axis {k}" if dim > 1 else ""))
        with about("positions"):
            self._check_particles(dim)
            check_size(f"the model {self.name!r}", len(self.positions),
                       np.prod([float(n) for n in self.nodes]), dim)
        with about("materials"):
            self._check_materials(dim)
        with about("particle_values"):
            self._check_particle_values()
        with about("initial_stress"):
            self._check_initial_stress(dim)
        self._check_scheme(dim, basis)
        with about("walls"):
            self._check_boundaries(dim, basis)
        with about("integrator"):
            self._check_integrator(basis)
        with about("dt"):
            set_("dt", positive("time step dt", self.dt))
        with about("water"):
            pores, arrays = checked_water(self)
            object.__setattr__(self, "pore_water", pores)
            object.__setattr__(self, "water_arrays", arrays)
        with about("planes"):
            object.__setattr__(self, "planes", checked_planes(self, dim))

    # ---- checks ----------------------------------------------------------------------
    def _check_particles(self, dim):
        set_ = lambda key, value: object.__setattr__(self, key, value)  # noqa: E731
        try:
            x = np.array(self.positions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("particle positions must be an array of numbers") from None
        x = x.reshape(-1, 1) if dim == 1 else x
        if x.ndim != 2 or x.shape[1] != dim:
            raise ValueError(f"particle positions must be an (n, {dim}) array, got shape "
                             f"{np.shape(self.positions)}")
        n = len(x)
        if n == 0:
            raise ValueError("a scene needs at least one particle")
        finite = np.all(np.isfinite(x), axis=1)
        if not finite.all():
            bad = int(np.flatnonzero(~finite)[0])
            raise ValueError(f"particle {bad} has a non-finite position {shown_point(x[bad])!r}")
        lo = np.array(self.origin)
        hi = lo + np.array(self.elements) * self.h
        outside = np.flatnonzero(np.any((x < lo) | (x > hi), axis=1))
        if len(outside):
            p = int(outside[0])
            where = (f"[{lo[0]}, {hi[0]}]" if dim == 1 else
                     f"[{tuple(float(v) for v in lo)}, {tuple(float(v) for v in hi)}]")
            raise ValueError(f"particle {p} at x = {shown_point(x[p])!r} lies outside the grid "
                             f"{where} ({len(outside)} particle(s) outside)")
        vol = np.array(self.volume, dtype=np.float64).ravel()
        if vol.shape != (n,):
            raise ValueError(f"volume has {len(vol)} entries for {n} particles")
        good = np.isfinite(vol) & (vol > 0)
        if not good.all():
            p = int(np.flatnonzero(~good)[0])
            raise ValueError(f"particle volume must be positive, particle {p} has "
                             f"{float(vol[p])!r}")
        if callable(self.velocity):
            v = field_function(self.velocity, x, "the initial velocity v0(X)")
        else:
            v = np.zeros_like(x) if self.velocity is None else np.array(self.velocity,
                                                                         np.float64)
        v = v.reshape(-1, 1) if dim == 1 else v
        if v.shape != x.shape:
            raise ValueError(f"velocity has {len(v)} entries for {n} particles"
                             + ("" if dim == 1 else f" (shape {v.shape}, need {x.shape})"))
        finite = np.all(np.isfinite(v), axis=1)
        if not finite.all():
            raise ValueError(f"particle {int(np.flatnonzero(~finite)[0])} has a "
                             "non-finite initial velocity")
        for key, arr in (("positions", x), ("volume", vol), ("velocity", v)):
            arr.setflags(write=False)
            set_(key, arr)
        self._check_displacement(x, lo, hi)

    def _check_displacement(self, X, lo, hi):
        """u0(X) and F0 = I + grad u0 of an initial displacement function, checked: the
        displaced particles inside the grid, det F0 > 0."""
        set_ = lambda key, value: object.__setattr__(self, key, value)  # noqa: E731
        if self.displacement is None:
            set_("initial_displacement", None)
            set_("initial_gradient", None)
            return
        if not callable(self.displacement):
            raise ValueError("displacement must be a function u0(X) of the (n, dim) reference "
                             "positions (its gradient is taken by central differences), got "
                             f"{type(self.displacement).__name__}")
        what = "the initial displacement u0(X)"
        u0 = field_function(self.displacement, X, what)
        n, dim = X.shape
        step = 1e-6 * self.h
        grad = np.empty((n, dim, dim))
        for k in range(dim):
            shift = np.zeros(dim)
            shift[k] = step
            plus = field_function(self.displacement, X + shift, what, signature=False)
            minus = field_function(self.displacement, X - shift, what, signature=False)
            grad[:, :, k] = (plus - minus) / (2 * step)
        det = np.linalg.det(np.eye(dim) + grad)
        bad = np.flatnonzero(~(det > 0))
        if len(bad):
            p = int(bad[0])
            raise ValueError(f"{what} inverts particle {p} at X = {shown_point(X[p])!r}: "
                             f"det(I + grad u0) = {det[p]:g} ({len(bad)} particle(s))")
        x = X + u0
        outside = np.flatnonzero(np.any((x < lo) | (x > hi), axis=1))
        if len(outside):
            p = int(outside[0])
            raise ValueError(f"{what} moves particle {p} from X = {shown_point(X[p])!r} to "
                             f"{shown_point(x[p])!r}, outside the grid ({len(outside)} "
                             "particle(s))")
        for key, arr in (("initial_displacement", u0), ("initial_gradient", grad)):
            arr.setflags(write=False)
            set_(key, arr)

    def _check_materials(self, dim):
        set_ = lambda key, value: object.__setattr__(self, key, value)  # noqa: E731
        mats = (self.materials,) if isinstance(self.materials, Material) else tuple(self.materials)
        if not mats:
            raise ValueError("a model needs at least one material")
        for k, m in enumerate(mats):
            if not isinstance(m, Material):
                raise ValueError(f"materials[{k}] must be a timpm material, got {m!r}")
            if dim not in m.dims:
                raise ValueError(f"the {m.name} material is defined in "
                                 f"{' and '.join(f'{d}D' for d in m.dims)}, not in {dim}D")
        set_("materials", mats)
        n = len(self.positions)
        index = (np.zeros(n, np.int32) if self.material_index is None else
                 _index_array("material_index", self.material_index, n, len(mats)))
        bodies = (np.zeros(n, np.int32) if self.body_index is None else
                  _index_array("body_index", self.body_index, n, np.iinfo(np.int32).max))
        density = np.array([m.density for m in mats])[index]
        mass = density * self.volume
        for key, arr in (("material_index", index), ("body_index", bodies), ("_mass", mass)):
            arr.setflags(write=False)
            set_(key, arr)

    def _check_particle_values(self):
        """``particle_values``: the initial values of law fields per particle (name -> (n,
        ...) finite array), every field a law of the model must be given (``GIVEN``:
        MohrCoulombField's strength) among them."""
        values = {} if self.particle_values is None else self.particle_values
        if not isinstance(values, dict):
            raise ValueError(f"particle_values must be a dict of field name -> (n, ...) "
                             f"array, got {type(values).__name__}")
        n, out = len(self.positions), {}
        for name, arr in values.items():
            a = np.array(arr, dtype=np.float64)
            if a.ndim < 1 or a.shape[0] != n:
                raise ValueError(f"particle_values[{name!r}] must hold one entry per "
                                 f"particle ({n}), got shape {a.shape}")
            if not np.all(np.isfinite(a)):
                bad = int(np.flatnonzero(~np.all(np.isfinite(a.reshape(n, -1)), axis=1))[0])
                raise ValueError(f"particle_values[{name!r}] of particle {bad} is not finite")
            a.setflags(write=False)
            out[name] = a
        for k, mat in enumerate(self.materials):
            for name in getattr(mat, "GIVEN", ()):
                if name not in out and np.any(self.material_index == k):
                    raise ValueError(f"the {mat.name} law reads each particle's {name}: "
                                     f"give it in particle_values[{name!r}] (a World does, "
                                     f"from a body's random_field)")
        object.__setattr__(self, "particle_values", out or None)

    def _check_initial_stress(self, dim):
        """The initial stresses (n, 3, 3), finite and symmetric, and the state each law
        takes from them (``initial_state``: its fields by name, ``Material.initial_state``)."""
        set_ = lambda key, value: object.__setattr__(self, key, value)  # noqa: E731
        if self.initial_stress is None:
            set_("initial_state", None)
            set_("initial_work", None)
            return
        n = len(self.positions)
        if dim == 1:
            raise ValueError("an initial stress is set in 2D and 3D models (its elastic state "
                             "is a Hencky law's); the 1D laws start from their own stress")
        if self.initial_displacement is not None:
            raise ValueError("a model starts from an initial displacement or from an initial "
                             "stress, not both")
        try:
            sig = np.array(self.initial_stress, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("initial_stress must be an (n, 3, 3) array of numbers") from None
        if sig.shape != (n, 3, 3):
            raise ValueError(f"initial_stress must be an (n, 3, 3) array of Cauchy stresses "
                             f"for the {n} particles (in 2D [2, 2] is sigma_zz), got shape "
                             f"{sig.shape}")
        bad = np.flatnonzero(~np.all(np.isfinite(sig), axis=(1, 2)))
        if len(bad):
            raise ValueError(f"initial_stress of particle {int(bad[0])} is not finite")
        asym = np.abs(sig - sig.transpose(0, 2, 1)).max(axis=(1, 2))
        bad = np.flatnonzero(asym > 1e-12 * (np.abs(sig).max(axis=(1, 2)) + 1e-300))
        if len(bad):
            raise ValueError(f"initial_stress of particle {int(bad[0])} is not symmetric")
        state = {}  # each law's state at that stress: its fields by name (F, ezz, ...)
        for k, mat in enumerate(self.materials):
            rows = np.flatnonzero(self.material_index == k)
            if len(rows):
                for name, value in mat.initial_state(sig[rows], dim).items():
                    value = np.asarray(value, dtype=np.float64)
                    if name not in state:
                        state[name] = np.zeros((n,) + value.shape[1:])
                    state[name][rows] = value
        F = state["F"]  # a Hencky law's elastic deformation gradient
        ezz = state.get("ezz", np.zeros(n))  # and its out-of-plane strain in plane strain
        # the energy stored in it, 1/2 sigma : eps V0 with eps = ln F_e (and zz in plane
        # strain): the strain energy the records start from
        w, Q = np.linalg.eigh(F)
        eps = np.einsum("nij,nj,nkj->nik", Q, np.log(w), Q)
        work = 0.5 * self.volume * (np.einsum("nij,nij->n", sig[:, :dim, :dim], eps)
                                    + (sig[:, 2, 2] * ezz if dim == 2 else 0.0))
        for arr in state.values():
            arr.setflags(write=False)
        set_("initial_state", state)
        for key, arr in (("initial_stress", sig), ("initial_work", work)):
            arr.setflags(write=False)
            set_(key, arr)

    def _check_scheme(self, dim, basis):
        params = check_scheme(dim, basis, self.transfer, self.mass_matrix, self.projection,
                              self.damping, transfer_params=self.transfer_params)
        object.__setattr__(self, "transfer_params", params)
        g = (0.0,) * dim if self.gravity is None else self.gravity
        object.__setattr__(self, "gravity", tuple(float(c) for c in vector("gravity", g, dim)))
        object.__setattr__(self, "damping", float(self.damping))
        if self.projection == "mls" and dim > 1:
            # the Gauss-point forces integrate over every cell: the body must fill the grid
            grid = float(np.prod([e * self.h for e in self.elements]))
            bodies = float(np.sum(self.volume))
            if abs(bodies - grid) > 1e-9 * grid:
                raise ValueError(f"in {dim}D the MLS projection integrates the stress over "
                                 f"every cell: the bodies must fill the grid (particle volumes "
                                 f"sum to {bodies:.6g}, the grid's volume is {grid:.6g})")

    def _check_integrator(self, basis):
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"unknown integrator {self.integrator!r}: choose one of "
                             f"{', '.join(INTEGRATORS)}")
        if self.integrator == "euler-cromer":
            return
        # rk4 and midpoint integrate the particles' equations of motion: every force a
        # function of the state and time, the grid velocity the mass-weighted projection
        midpoint = self.integrator == "midpoint"
        takes = [t for t in SCHEME_TRANSFERS if self.integrator in _integrators(t)]
        conflicts = [what for what, present in (
            (f"the {self.transfer} transfer (it takes {', '.join(takes)})",
             self.integrator not in _integrators(self.transfer)),
            ("the study's MLS projection (linear basis, lumped mass: its nodal velocities)",
             self.projection == "mls" and basis.support == 2 and self.mass_matrix == "lumped"),
            ("local damping", self.damping > 0.0), ("a PIC fraction", self.pic_fraction > 0.0),
            ("slip, friction or driven walls (roller and sticky walls are linear "
             "constraints: those it takes)",
             any(w is not None and (w.kind not in ("roller", "sticky") or w.moves)
                 for w in self.walls or ())),
            ("prescribed non-zero node velocities", self.prescribes_motion),
            ("the particle traction", self.traction is not None),
            ("surface tractions", self.particle_force is not None),
            ("a body force in the current frame (give it in the reference frame)",
             self.body_force is not None and self.body_force.frame != "reference"))
            if present]
        laws = sorted({m.name for m in self.materials if not m.stress_from_F})
        if laws:
            exact = (": the study's 1D law is, integrated exactly (stress_update "
                     "'study-exact' or 'small-exact')" if "hypoelastic-1d" in laws else "")
            conflicts.append(f"the {', '.join(laws)} law (its stress is not a function of F "
                             f"alone{exact})")
        if conflicts:
            what = ("midpoint' (the energy-conserving midpoint iteration" if midpoint else
                    "rk4' (Runge-Kutta on the particles' equations")
            raise ValueError(f"integrator '{what}) does not take {'; '.join(conflicts)}")

    def _check_boundaries(self, dim, basis):
        set_ = lambda key, value: object.__setattr__(self, key, value)  # noqa: E731
        n = len(self.positions)
        walls = self.walls
        if walls is not None:
            walls = tuple(walls)
            if len(walls) != 2 * dim or not all(w is None or isinstance(w, Wall) for w in walls):
                raise ValueError(f"walls must be {2 * dim} Walls or None, one per side "
                                 f"({', '.join(SIDES[:2 * dim])}), got {self.walls!r}")
            if all(w is None for w in walls):
                walls = None
        for side, w in zip(SIDES, walls or ()):
            if w is not None and w.moves:
                axis = SIDES.index(side) // 2
                if len(w.velocity) != dim:
                    raise ValueError(f"the {side} wall's velocity must have {dim} components, "
                                     f"got {w.velocity!r}")
                if w.velocity[axis] != 0.0:
                    raise ValueError(f"the {side} wall's velocity must lie along the wall (it "
                                     f"stays in place): its component {'xyz'[axis]} is "
                                     f"{w.velocity[axis]:g}, not 0")
        # the study's MLS projection (linear basis) reconstructs the nodal velocities
        study_mls = self.projection == "mls" and basis.support == 2
        bad = sorted({w.kind + " moving" * w.moves for w in walls or () if w is not None
                      and (w.kind not in ("roller", "sticky") or w.moves)})
        if bad and self.mass_matrix != "lumped" and dim > 1:
            raise ValueError("with the consistent mass in 2D and 3D the walls must be roller "
                             f"or fixed sticky walls (constraints of the solve), not {bad}")
        if walls is not None and ((self.mass_matrix != "lumped" and dim == 1) or study_mls):
            raise ValueError("walls act on the lumped nodal velocities: with the consistent "
                             "mass or the study's MLS projection (linear basis) hold the end "
                             "nodes fixed instead (fixed_nodes)")
        set_("walls", walls)
        self._check_periodic(dim, basis)
        cells = self.wall_cells
        if cells is None:
            cells = tuple((0.0, float(e)) for e in self.elements)
        try:
            cells = tuple((float(lo), float(hi)) for lo, hi in cells)
        except (TypeError, ValueError):
            raise ValueError(f"wall_cells must be one (lower, upper) pair per axis, got "
                             f"{self.wall_cells!r}") from None
        if len(cells) != dim or any(not (0 <= lo < hi <= e) for (lo, hi), e
                                    in zip(cells, self.elements)):
            raise ValueError(f"wall_cells must be one (lower, upper) pair per axis within the "
                             f"grid's elements {self.elements}, got {self.wall_cells!r}")
        set_("wall_cells", cells)
        nodes = self.nodes
        fixed, velocities = [], []
        given = self.fixed_nodes
        if isinstance(given, dict):
            entries = list(given.items())
        else:
            try:
                entries = [(i, None) for i in given]
            except TypeError:
                raise ValueError(f"fixed_nodes must be node indices or a dict of node to "
                                 f"prescribed velocity, got {given!r}") from None
        for i, velocity in entries:
            velocities.append(np.zeros(dim) if velocity is None else
                              vector(f"prescribed velocity of fixed node {i!r}", velocity, dim))
            idx = (i,) if np.ndim(i) == 0 else tuple(i)
            if len(idx) != dim or not all(isinstance(c, (int, np.integer))
                                          and not isinstance(c, bool) for c in idx):
                raise ValueError(f"fixed node {i!r} must be {dim} whole number(s) (a node index"
                                 f"{' per axis' if dim > 1 else ''})")
            if not all(0 <= c < nn for c, nn in zip(idx, nodes)):
                top = nodes[0] - 1 if dim == 1 else tuple(nn - 1 for nn in nodes)
                raise ValueError(f"fixed node {idx[0] if dim == 1 else idx} does not exist: the "
                                 f"grid has nodes 0..{top}")
            fixed.append(tuple(int(c) for c in idx))
        if len(set(fixed)) != len(fixed):
            raise ValueError("a fixed node is given twice in fixed_nodes")
        set_("fixed_nodes", tuple(fixed))
        velocities = np.array(velocities, dtype=np.float64).reshape(len(fixed), dim)
        velocities.setflags(write=False)
        set_("fixed_velocity", velocities)
        set_("fixed_time", time_function("fixed_time", self.fixed_time))
        if self.prescribes_motion and (self.mass_matrix != "lumped"
                                       or self.projection != "standard"):
            raise ValueError("prescribed non-zero node velocities are implemented for the "
                             "lumped mass and the standard projection: hold the nodes at "
                             "zero (a list of nodes) or use mass='lumped'")
        if self.body_force is not None:
            if not isinstance(self.body_force, BodyForce):
                raise ValueError(f"body_force must be a timpm.model.loads.BodyForce (a function "
                                 f"b(X, t) wrapped), got {self.body_force!r}")
            self.body_force(self.positions, 0.0)  # signature, shape, finite: checked now
        if self.particle_force is not None:
            try:
                f = np.array(self.particle_force, dtype=np.float64).reshape(n, dim)
            except (TypeError, ValueError):
                raise ValueError(f"particle_force must be an ({n}, {dim}) array of forces, "
                                 f"got shape {np.shape(self.particle_force)}") from None
            if not np.all(np.isfinite(f)):
                raise ValueError("particle_force must be finite")
            f.setflags(write=False)
            set_("particle_force", f if np.any(f != 0.0) else None)
        set_("particle_force_time", time_function("particle_force_time",
                                                  self.particle_force_time))
        if self.traction is not None:
            if dim != 1:
                raise ValueError("the particle traction (3.5) acts along x in 1D models only")
            if not 0 <= self.traction.particle < n:
                raise ValueError(f"traction particle {self.traction.particle} does not exist "
                                 f"({n} particles)")

    # ---- derived -----------------------------------------------------------------------
    @property
    def pic_fraction(self) -> float:
        """The musl transfer's PIC share b (0 where the transfer has none)."""
        return self.transfer_params.get("pic_fraction", 0.0)

    @property
    def prescribes_motion(self) -> bool:
        """Some fixed node has a non-zero prescribed velocity, or a wall moves."""
        return bool(np.any(self.fixed_velocity != 0.0)) or self.moving_walls

    @property
    def moving_walls(self) -> bool:
        return self.walls is not None and any(w is not None and w.moves for w in self.walls)

    @property
    def dim(self) -> int:
        return len(self.elements)

    @property
    def periodic(self) -> bool:
        """Whether x is periodic (``periodic`` walls on the left and the right)."""
        return self.walls is not None and self.walls[0] is not None and \
            self.walls[0].kind == "periodic"

    @property
    def nodes(self) -> tuple:
        basis = self.basis
        nodes = tuple(basis.n_nodes(e) for e in self.elements)
        if self.periodic:  # the last column of nodes is the first
            nodes = (self.elements[0],) + nodes[1:]
        return nodes

    def _check_periodic(self, dim, basis):
        """Periodic walls: both x sides (only x), the linear basis, the lumped step."""
        sides = [s for s, w in zip(SIDES, self.walls or ()) if w is not None
                 and w.kind == "periodic"]
        if not sides:
            return
        if sides != ["left", "right"]:
            raise ValueError(f"periodic walls come as a pair on the left and the right side "
                             f"(x periodic; y and z cannot be), got them on {', '.join(sides)}")
        wrong = [what for what, bad in (
            ("1D (a periodic bar has no wall to stand on)", dim == 1),
            (f"the {basis.name} basis (the linear one only: the B-splines' end functions "
             "and padding are not periodic)", basis.name != "linear"),
            ("the consistent mass", self.mass_matrix != "lumped"),
            ("the MLS projection", self.projection != "standard"),
            (f"the {self.integrator} integrator", self.integrator != "euler-cromer"),
            ("wall_cells along x", self.wall_cells is not None
             and tuple(map(float, self.wall_cells[0])) != (0.0, float(self.elements[0])))) if bad]
        if wrong:
            raise ValueError(f"periodic walls do not take {'; '.join(wrong)}")
        if self.elements[0] < 2:
            raise ValueError("a periodic x needs at least 2 elements along x")

    @property
    def n_particles(self) -> int:
        return len(self.positions)

    @property
    def mass_per_particle(self) -> np.ndarray:
        return self._mass

    def plane_nodes(self, k=None) -> np.ndarray:
        """The grid nodes plane ``k`` holds (all planes: None), a boolean array of the
        nodes' shape: those on or beyond it, (x_i - p) . n >= -PLANE_TOLERANCE h with x_i
        the node's position (basis.node_coordinates: the control points of the clamped
        B-splines), as the kernels find them (timpm/engine/grid.py)."""
        return plane_nodes(self, k)

    def wall_nodes(self) -> tuple:
        """Per axis the last node at or below the lower wall and the first node at or
        above the upper wall (node coordinates of the basis): the nodes a wall acts on."""
        basis = self.basis
        out = []
        for (lo, hi), e in zip(self.wall_cells, self.elements):
            x = basis.node_coordinates(e)
            tol = 1e-9 * max(1.0, e)
            out.append((int(np.flatnonzero(x <= lo + tol)[-1]) if np.any(x <= lo + tol) else -1,
                        int(np.flatnonzero(x >= hi - tol)[0]) if np.any(x >= hi - tol)
                        else len(x)))
        return tuple(out)

