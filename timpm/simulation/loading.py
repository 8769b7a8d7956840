"""Initial stresses by gravity loading: the ground brought to rest under its own weight.

The other procedure of :mod:`timpm.model.geostatic` (the K0 procedure writes a stress down; this
one computes it): the scene runs from its initial state (stress-free, or the K0 stress)
with gravity and the local damping of A.4 on the MUSL transfer until its kinetic energy
is a ``tolerance`` of its weight times its height, or ``t_max`` has passed; the stresses
it reached become the scene's initial stress, its particles back at their drawn positions
(the settlement is not part of what follows, as in finite-element practice).  Where the
ground can stand, this is an equilibrium of the discrete forces, also near a slope's face
where the K0 stress is not one.
"""
import math
from dataclasses import replace

import numpy as np

from ..model.geostatic import GravityLoading

__all__ = ["GravityLoading", "gravity_loading", "check_gravity_loading", "NotAtRest"]


def _stress3(solver, world):
    """The particles' Kirchhoff stresses tau = J sigma as (n, 3, 3): the stress the laws
    hold (their surfaces are written in it), which the loaded scene starts from at V = V0;
    in 2D tau_zz from the out-of-plane elastic strain of the laws that keep one
    (Mohr-Coulomb), else zero."""
    model = world.model
    J = solver.read("vol") / model.volume  # V / V0
    sig = solver.read("sigma") * J[:, None, None]
    n, d = sig.shape[0], world.dim
    out = np.zeros((n, 3, 3))
    out[:, :d, :d] = sig
    if d == 2 and "ezz" in solver.program().particle_fields:
        F, ezz = solver.read("F"), solver.read("ezz")
        lam = np.array([getattr(m, "lam", 0.0) for m in model.materials])[model.material_index]
        mu = np.array([getattr(m, "mu", 0.0) for m in model.materials])[model.material_index]
        tr = np.log(np.abs(np.linalg.det(F))) + ezz
        out[:, 2, 2] = lam * tr + 2.0 * mu * ezz
    return out


def _check_gravity(world):
    """The loading weighs the ground along -y (its height, its weight and the K0-like rest
    it reaches are measured along y): gravity must have a downward y component (tilted,
    as an infinite slope's frame, is fine)."""
    g = tuple(float(v) for v in world.gravity)
    if world.dim < 2:
        raise ValueError("gravity loading brings 2D and 3D ground to rest under its weight; "
                         "a 1D world starts from its laws' own stress")
    if not any(g):
        raise ValueError("gravity loading brings the ground to rest under its weight, and "
                         "gravity is zero: there is no weight to load it with; give [loads] "
                         "gravity (down y), or drop [initial_stress] (no initial stress)")
    if not g[1] < 0.0:
        raise ValueError(f"gravity loading weighs the ground along -y (its height and its "
                         f"weight are measured along y), and gravity = {g} has "
                         f"{'no' if g[1] == 0.0 else 'an upward'} y component: point [loads] "
                         "gravity down y (a tilted gravity with a downward y component is "
                         "taken), or give the initial stress another way")


def _check_materials(world):
    """The stress the loading reaches becomes the world's initial stress, which only laws
    with a Hencky elastic part take (``Material.initial_state``): the others are refused
    before the loading runs, not after."""
    for k, m in enumerate(world.model.materials):
        probe = getattr(m, "initial_state", None)
        try:
            if probe is None:
                raise ValueError(f"{m.name}: a fluid has no elastic strain to hold an initial "
                                 "stress")
            probe(np.zeros((1, 3, 3)), world.dim)  # (the unloaded state: inside any surface)
        except ValueError as err:
            bodies = [b.name or f"body {i}" for i, b in enumerate(world.bodies)
                      if b.material is m or b.material == m]
            raise ValueError(f"gravity loading keeps the stress it reaches as every body's "
                             f"initial stress, and {', '.join(bodies) or 'a body'} cannot "
                             f"start from one: {err}; make its material drucker-prager or "
                             "mohr-coulomb, or drop [initial_stress]") from None


def _check_length(t_max, dt, allow_many_steps, default):
    """The loading's whole length in steps before it starts (its chunks are shorter: a
    t_max that no chunk refuses may still be billions of steps)."""
    from ..platform.checks import MAX_STEPS

    steps = t_max / dt
    if steps <= MAX_STEPS or (allow_many_steps and steps < 2 ** 62):
        return
    raise ValueError(f"gravity loading: t_max = {t_max:g} s at dt = {dt:.3g} s takes "
                     f"{steps:.3g} steps, more than the {MAX_STEPS:.0e} a run may take unless "
                     f"allowed: give [initial_stress] t_max a shorter time (the default, 40 "
                     f"times a P-wave's time across the ground's height, is {default:.3g} s "
                     "here), or pass --allow-many-steps (allow_many_steps=True) to run it "
                     "anyway")


class NotAtRest(ValueError):
    """The gravity loading ran to its t_max and the ground did not come to rest (it may not
    stand as drawn): the one refusal that is the ground's answer, not a setting's (the
    factor-of-safety study reads it as a failed trial)."""


def _plan(world, spec, allow_many_steps):
    """The loading's spec, world, t_max and the ground's height, every check made before
    the loading runs."""
    spec = spec or (world.initial_stress if isinstance(world.initial_stress, GravityLoading)
                    else GravityLoading())
    _check_gravity(world)
    _check_materials(world)
    y = world.model.positions[:, 1]
    height = float(y.max() - y.min()) or world.h
    wave = max(m.wave_speed for m in world.model.materials)
    default = 40.0 * height / wave
    t_max = spec.t_max if spec.t_max is not None else default
    start = world.initial_stress if not isinstance(world.initial_stress, GravityLoading) else None
    loading = replace(world, transfer="musl", damping=spec.damping, pic_fraction=0.0,
                      transfer_params=None,
                      integrator="euler-cromer", initial_stress=start)
    if t_max < 40.0 * loading.dt:
        raise ValueError(f"gravity loading: t_max = {t_max:g} s is shorter than 40 time steps "
                         f"(dt = {loading.dt:.3g} s): the ground cannot be loaded and come to "
                         "rest in it; give a longer t_max (default: 40 times a P-wave's time "
                         "across the ground's height)")
    _check_length(t_max, loading.dt, allow_many_steps, default)
    return spec, loading, t_max, height


def check_gravity_loading(world, spec=None, allow_many_steps=False) -> float:
    """The checks :func:`gravity_loading` makes before it runs (a ValueError naming what to
    change), made alone: for a caller that loads the ground many times (a study) and
    refuses a setting before its first run; returns the loading's t_max."""
    return _plan(world, spec, allow_many_steps)[2]


def gravity_loading(world, spec=None, progress=None, allow_many_steps=False):
    """``world`` with the initial stress its gravity loading reaches (``spec``: a
    :class:`GravityLoading`, default the world's own ``initial_stress`` or the defaults);
    returns (that world, the loading's record: time, kinetic energy ratio, largest
    settlement, whether it came to rest).  Refused before the loading runs
    (:func:`check_gravity_loading`): a gravity without a downward y component, a body
    whose law takes no initial stress, a t_max of fewer than 40 steps or (unless
    ``allow_many_steps``) more than 1e8.  Ground that does not come to rest raises
    :class:`NotAtRest`.  Interrupted (:class:`~timpm.platform.interrupt.RunInterrupted`),
    the exception's ``loading`` says where: the loading run's step and time, and its
    t_max."""
    from ..platform.interrupt import RunInterrupted
    from .solver import Solver

    spec, loading, t_max, height = _plan(world, spec, allow_many_steps)
    weight = float(np.sum(loading.model.mass_per_particle)) * abs(world.gravity[1]) * height
    s = Solver(loading, energies=True)
    X = loading.model.positions
    try:
        rest, t, ratio = False, 0.0, math.inf
        chunk = t_max / 40.0
        while t < t_max * (1 - 1e-12):
            t = min(t + chunk, t_max)
            try:
                s.run(t_end=t, allow_many_steps=allow_many_steps)
            except RunInterrupted as stop:  # where the loading stopped, for the caller
                stop.loading = {"step": stop.step, "t": stop.t, "t_max": t_max}
                raise
            ratio = float(s.energies()["kinetic"][-1]) / weight
            if progress is not None:
                progress(f"gravity loading: t = {t:.3g} s, kinetic energy {ratio:.2e} of the "
                         "weight times the height")
            if ratio <= spec.tolerance and t >= 0.25 * t_max:
                rest = True
                break
        stress = _stress3(s, loading)
        record = {"t": t, "kinetic_ratio": ratio, "at_rest": rest, "t_max": t_max,
                  "damping": spec.damping,
                  "settlement": float(np.abs(s.positions() - X)[:, 1].max())}
    finally:
        s.release()
    if not rest:
        raise NotAtRest(f"gravity loading did not come to rest within t_max = {t_max:g} s "
                         f"(kinetic energy {ratio:.2e} of the weight times the height, "
                         f"tolerance {spec.tolerance:g}): the ground may not stand as drawn, "
                         "or give a longer t_max")
    return replace(world, initial_stress=stress), record
