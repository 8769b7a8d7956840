"""Why a run stops: the error record the kernels keep (code, step, particle or node:
:meth:`Failures.fail`, the unit below every other), and in Python that record and the
energy balance of the recorded energies, each as a :class:`~timpm.platform.errors.SimulationError`
that names the step and where."""
import numpy as np
import taichi as ti

from ..platform.errors import ErrorCode, SimulationError, TEAM_SPIN_LIMIT
from ..schemes.midpoint import MIDPOINT_MAX_ITERATIONS
from .consistent_mass_cg import CG_MAX_ITERATIONS

__all__ = ["Failures", "recorded_failure", "energy_balance"]


class Failures:
    """The error record written by the kernels: the run fields ``err``, ``err_count``,
    ``err_step``, ``err_where``, ``neg_pivots`` and ``step_count`` (``run``), a team's
    ``rank_step`` (the step each thread is in) and the run-time values."""

    def __init__(self, features, run, rank_step, values):
        self.mode, self.team = features.mode, features.team
        self.run, self.rank_step, self.values = run, rank_step, values

    @ti.func
    def fail(self, code, where):
        """Record the first error of the run: its code (an
        :class:`~timpm.platform.errors.ErrorCode`), step and particle or node."""
        first = False
        if ti.static(self.mode == "serial"):
            first = self.run.err_count[None] == 0
            self.run.err_count[None] = self.run.err_count[None] + 1
        else:
            first = ti.atomic_add(self.run.err_count[None], 1) == 0
        if first:
            self.run.err[None] = code
            if ti.static(self.team):  # where: a particle of the thread's block
                self.run.err_step[None] = self.rank_step[where // self.values.scatter_block()]
            else:
                self.run.err_step[None] = self.run.step_count[None]
            self.run.err_where[None] = where

    @ti.func
    def count_negative_pivot(self):
        """One more negative pivot of the consistent mass (an indefinite matrix: quadratic
        Lagrange elements), reported with the run."""
        if ti.static(self.mode == "serial"):
            self.run.neg_pivots[None] = self.run.neg_pivots[None] + 1
        else:
            self.run.neg_pivots[None] += 1

    @ti.func
    def failed(self):
        """Whether the run has recorded an error (in this step or before)."""
        return self.run.err_count[None] != 0

    @ti.func
    def halted(self, p):
        """A step before this one failed: the particles stay as they were at the failure
        (Python reads the error back every ``check_every`` steps).  The fused serial mode
        stops before the step after a failure instead (see ``advance_steps``), a team at
        the first barrier after it (its step is that of particle p's thread)."""
        halted = False
        if ti.static(self.team):
            halted = (self.run.err_count[None] != 0 and
                      self.run.err_step[None] < self.rank_step[p // self.values.scatter_block()])
        elif ti.static(self.mode != "serial"):
            halted = (self.run.err_count[None] != 0
                      and self.run.err_step[None] < self.run.step_count[None])
        return halted


def recorded_failure(prog, state):
    """The first failure in ``prog``'s error record as a :class:`SimulationError` that
    names step, particle or node and the cause (``state``: the scene ``prog`` holds), or
    None."""
    code = int(prog.err[None])
    if code == 0:
        return None
    code = ErrorCode(code)
    lay, model = state.layout, state.model
    step, where = int(prog.err_step[None]) + 1, int(prog.err_where[None])
    when = f"step {step} (t = {step * model.dt:g} s)"
    if code == ErrorCode.TEAM_BARRIER:
        block = lay.values["scatter_block"]
        return SimulationError(
            f"{when}: {code.message} (thread {where // block} waited {TEAM_SPIN_LIMIT} "
            "spins): Taichi's pool ran the team on fewer threads than it has; use "
            "mode='parallel'", code, step)
    if code == ErrorCode.SINGULAR_MASS:
        return SimulationError(f"{when}: {code.message} at node {where}", code, step,
                               node=where)
    if code == ErrorCode.MASS_SOLVE:
        return SimulationError(f"{when}: {code.message} in {CG_MAX_ITERATIONS} iterations; "
                               "the mass matrix is near singular (nodes that particles "
                               "barely touch): raise small_mass or use the lumped mass",
                               code, step)
    if code == ErrorCode.MIDPOINT and where < 0:
        return SimulationError(f"{when}: {code.message} in {MIDPOINT_MAX_ITERATIONS} "
                               "passes; its passes slow down as dt nears the critical step "
                               "and fail beyond it: take a smaller dt", code, step)
    x = prog.x[where].to_numpy()
    if state.features.dim == 1:
        lo, hi = lay.origin[0], lay.origin[0] + lay.elements[0] * lay.h
        at = f"x = {float(x[0]):g}, grid [{lo:g}, {hi:g}]"
    else:
        xs = ", ".join(f"{c:g}" for c in x)
        hi = ", ".join(f"{o + n * lay.h:g}" for o, n in zip(lay.origin, lay.elements))
        at = f"x = ({xs}), grid from ({', '.join(f'{o:g}' for o in lay.origin)}) to ({hi})"
    msg = f"{when}: particle {where} {code.message} ({at})"
    if code == ErrorCode.MIDPOINT:
        return SimulationError(f"{when}: {code.message}: the iterate of particle {where}'s F "
                               f"inverted (det F <= 0) or left the finite numbers ({at}); "
                               "the step is too large for the motion: take a smaller dt",
                               code, step, particle=where)
    if code == ErrorCode.VOLUME_RANGE:
        lo, hi = (lay.values[k] for k in ("volume_min", "volume_max"))
        density = model.materials[int(model.material_index[where])].density
        ratio = float(prog.vol[where]) * density / float(prog.m[where])
        msg += (f": V/V0 = {ratio:.3g} outside [{lo:g}, {hi:g}]; refine the grid or the "
                "time step, or pass volume_range=None (or a wider range) to go on")
    if code == ErrorCode.NOT_FINITE:
        msg += "; the run is unstable: check the time step and the mass matrix"
    return SimulationError(msg, code, step, particle=where)


def energy_balance(first, energy, steps, supplied_before, guard, dt):
    """The energy supplied up to the last of the records ``energy`` (rows of kinetic,
    strain, gravity, external work at ``steps``; ``first``: the run's first record;
    ``supplied_before``: up to the previous records) and a :class:`SimulationError` for
    the first record whose kinetic + strain energy exceeds ``guard`` times the energy
    supplied (initial kinetic and strain energy plus the magnitudes of the gravity and
    external work), or None."""
    base = first[0] + max(first[1], 0.0)
    # energy put in: initial kinetic + strain, and the work of gravity and tractions
    supplied = base + np.abs(energy[:, 2] - first[2]) + np.abs(energy[:, 3] - first[3])
    supplied = np.maximum.accumulate(np.maximum(supplied, supplied_before))
    moving = energy[:, 0] + energy[:, 1]
    bad = np.flatnonzero(moving > guard * supplied + 1e-300)
    if not len(bad):
        return float(supplied[-1]), None
    i = int(bad[0])
    return float(supplied[-1]), SimulationError(
        f"step {int(steps[i])} (t = {int(steps[i]) * dt:g} s): "
        f"{ErrorCode.ENERGY_GROWTH.message}: kinetic + strain energy {moving[i]:.4g} J "
        f"exceeds {guard:g} x the {supplied[i]:.4g} J supplied; the run is "
        "unstable (too few particles per element, too large a time step, or an "
        "indefinite mass matrix)", ErrorCode.ENERGY_GROWTH, int(steps[i]))
