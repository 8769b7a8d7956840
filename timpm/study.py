"""Drivers: run a benchmark problem, compare with its exact solution, study convergence."""
from dataclasses import dataclass, field
import time

import numpy as np

from .analysis import energy_drift, observed_rates, rms_error
from .problems import get_problem
from .solver import Solver

__all__ = ["RunResult", "run_problem", "convergence"]


@dataclass
class RunResult:
    """One run: the JSON record, final particle state and the monitored time series."""

    record: dict
    x0: np.ndarray
    displacement: np.ndarray
    exact_displacement: np.ndarray | None
    series: dict = field(default_factory=dict)
    energies: dict | None = None


def _default_record_every(steps: int) -> int:
    return max(1, steps // 10000)


def run_problem(problem="vibrating-string", *, elements=None, ppc=None, basis="linear",
                mass="lumped", dt=None, t_end=None, placement="study", stress_update="study",
                damping=None, allow_unstable_dt=False, mode="auto", record_every=None,
                progress=None, params=None, energies=True, projection="standard") -> RunResult:
    """Build the problem's scene, run it to ``t_end`` and compare with the exact solution.

    Unset numerical values take the problem's defaults; ``params`` overrides physical
    parameters (e.g. ``{"p0": 5e4}``).  The record holds at least problem, elements, ppc,
    basis, mass, dt, t_end, steps, rms_error, wall_seconds (stepping only; compilation is
    ``compile_seconds``) and grid_crossings.
    """
    prob = get_problem(problem, **(params or {}))
    elements = prob.elements if elements is None else elements
    ppc = prob.ppc if ppc is None else ppc
    t_end = prob.t_end if t_end is None else float(t_end)
    scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=dt,
                       placement=placement, stress_update=stress_update,
                       allow_unstable_dt=allow_unstable_dt, damping=damping,
                       projection=projection)
    x0 = scene.positions.copy()
    monitor = prob.monitored_particle(x0)
    steps = int(round(t_end / scene.dt))
    every = _default_record_every(steps) if record_every is None else int(record_every)
    t_build = time.perf_counter()
    solver = Solver(scene, track=[monitor], record_every=every, energies=energies, mode=mode)
    build_seconds = time.perf_counter() - t_build
    try:
        solver.run(t_end, progress=progress)
        t = solver.t
        u = solver.displacements()
        exact = prob.displacement(x0, t, stress_update=stress_update) if prob.has_exact else None
        series = solver.tracked()
        series = {"t": series["t"], "particle": monitor, "x0": float(x0[monitor]),
                  "u": series["u"][:, 0], "v": series["v"][:, 0], "stress": series["stress"][:, 0]}
        if prob.has_exact:
            series["u_exact"] = np.array([prob.displacement(x0[monitor:monitor + 1], s,
                                                            stress_update=stress_update)[0]
                                          for s in series["t"]])
            series["v_exact"] = np.array([prob.velocity(x0[monitor:monitor + 1], s)[0]
                                          for s in series["t"]])
        en = solver.energies() if energies else None
        record = {
            "problem": prob.name, "elements": int(elements), "ppc": int(ppc),
            "basis": scene.basis, "mass": scene.mass, "dt": scene.dt, "t_end": t,
            "steps": solver.step, "rms_error": rms_error(u, exact) if exact is not None else None,
            "wall_seconds": solver.run_seconds, "compile_seconds": solver.compile_seconds,
            "build_seconds": build_seconds, "grid_crossings": solver.grid_crossings(),
            "particles": scene.n_particles, "placement": placement,
            "stress_update": stress_update, "projection": projection, "mode": solver.mode,
            "critical_dt": scene.critical_dt, "monitored_particle": monitor,
            # damping dissipates energy by design: no conservation measure then
            "energy_drift": energy_drift(en) if en is not None and scene.damping == 0 else None,
        }
        if scene.mass == "consistent":
            record["negative_pivots"] = solver.negative_pivots()
        record.update(prob.summary(x0, solver, stress_update))
        return RunResult(record, x0, u, exact, series, en)
    finally:
        solver.release()


def convergence(problem="vibrating-string", elements=(4, 8, 16, 32, 64), **kwargs) -> dict:
    """Run the problem on each mesh; returns the records and the observed rates."""
    if len(elements) == 0:
        raise ValueError("give at least one number of elements")
    results = [run_problem(problem, elements=n, **kwargs) for n in elements]
    records = [r.record for r in results]
    doc = {"problem": records[0]["problem"], "runs": records}
    errors = [r["rms_error"] for r in records]
    if all(e is not None for e in errors):
        doc["rates"] = observed_rates([r["elements"] for r in records], errors)
    return doc


def compare_large_column(elements=30, ppc=50, dt=1e-3, t_end=3.0, basis="linear",
                         mass="lumped") -> dict:
    """MPM against the updated-Lagrangian FEM on the large-deformation column of A.5.

    Returns the position over time of the point initially at y = 0.5 m from both (the MPM
    particle just below it, the ULFEM node at it), and the oscillation periods taken, as
    the study does, from successive maxima of the potential (strain + gravitational) energy:
    it peaks at both turning points, so the period is twice the spacing of its maxima.
    """
    from .ulfem import large_column, period_from_maxima

    mpm = run_problem("large-column", elements=elements, ppc=ppc, dt=dt, t_end=t_end,
                      basis=basis, mass=mass, record_every=1)
    fem = large_column(n_elements=elements, dt=dt, t_end=t_end)
    en = mpm.energies
    potential = en["strain"] + en["gravity"]
    return {
        "mpm": {"t": mpm.series["t"], "position": mpm.series["x0"] + mpm.series["u"],
                "period": 2.0 * period_from_maxima(en["t"], potential),
                "position_period": period_from_maxima(mpm.series["t"], mpm.series["u"]),
                "record": mpm.record},
        "ulfem": {"t": fem["t"], "position": fem["position"], "period": fem["period"],
                  "position_period": fem["position_period"]},
        "study_periods": {"mpm": 0.374, "ulfem": 0.364},
    }


def displacement_fields(problem="vibrating-string", elements=4, ppc=4, dt=1e-3, t_end=0.5,
                        variants=(("lagrange2", "consistent"), ("linear", "lumped")),
                        points_per_element=1000) -> dict:
    """u_h(x) = sum_i phi_i(x) u_i on a fine grid of points for each (basis, mass), with
    the exact displacement (the study's Figures 5.5 and 5.6)."""
    prob = get_problem(problem)
    x = np.linspace(0.0, prob.domain_length(), elements * points_per_element + 1)
    out = {"x": x, "problem": prob.name, "elements": elements, "fields": {}}
    for basis, mass in variants:
        scene = prob.scene(elements=elements, ppc=ppc, basis=basis, mass=mass, dt=dt)
        solver = Solver(scene, grid_displacement=True, energies=False)
        try:
            solver.run(t_end)
            out["fields"][f"{basis}, {mass}"] = solver.displacement_field(x)
            out["t"] = solver.t
        finally:
            solver.release()
    out["exact"] = prob.displacement(x, out["t"])
    return out
