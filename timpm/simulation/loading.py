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

__all__ = ["GravityLoading", "gravity_loading"]


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


def gravity_loading(world, spec=None, progress=None):
    """``world`` with the initial stress its gravity loading reaches (``spec``: a
    :class:`GravityLoading`, default the world's own ``initial_stress`` or the defaults);
    returns (that world, the loading's record: time, kinetic energy ratio, largest
    settlement, whether it came to rest)."""
    from .solver import Solver

    spec = spec or (world.initial_stress if isinstance(world.initial_stress, GravityLoading)
                    else GravityLoading())
    y = world.model.positions[:, 1]
    height = float(y.max() - y.min()) or world.h
    wave = max(m.wave_speed for m in world.model.materials)
    t_max = spec.t_max if spec.t_max is not None else 40.0 * height / wave
    start = world.initial_stress if not isinstance(world.initial_stress, GravityLoading) else None
    loading = replace(world, transfer="musl", damping=spec.damping, pic_fraction=0.0,
                      transfer_params=None,
                      integrator="euler-cromer", initial_stress=start)
    weight = float(np.sum(loading.model.mass_per_particle)) * abs(world.gravity[1]) * height
    if t_max < 40.0 * loading.dt:
        raise ValueError(f"gravity loading: t_max = {t_max:g} s is shorter than 40 time steps "
                         f"(dt = {loading.dt:.3g} s): the ground cannot be loaded and come to "
                         "rest in it; give a longer t_max (default: 40 times a P-wave's time "
                         "across the ground's height)")
    s = Solver(loading, energies=True)
    X = loading.model.positions
    try:
        rest, t, ratio = False, 0.0, math.inf
        chunk = t_max / 40.0
        while t < t_max * (1 - 1e-12):
            t = min(t + chunk, t_max)
            s.run(t_end=t)
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
        raise ValueError(f"gravity loading did not come to rest within t_max = {t_max:g} s "
                         f"(kinetic energy {ratio:.2e} of the weight times the height, "
                         f"tolerance {spec.tolerance:g}): the ground may not stand as drawn, "
                         "or give a longer t_max")
    return replace(world, initial_stress=stress), record
