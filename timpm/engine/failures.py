"""Why a run stops, read in Python: the error record the kernels keep (code, step, particle
or node: ``Drivers.fail``) and the energy balance of the recorded energies, each as a
:class:`~timpm.errors.SimulationError` that names the step and where."""
import numpy as np

from ..errors import ErrorCode, SimulationError, TEAM_SPIN_LIMIT
from .consistent_mass_cg import CG_MAX_ITERATIONS
from .midpoint import MIDPOINT_MAX_ITERATIONS

__all__ = ["recorded_failure", "energy_balance"]


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
