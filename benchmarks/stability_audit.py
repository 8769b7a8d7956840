"""Stability audit: every basis x mass x placement x transfer at 0.5x and 0.9x its critical
time step, energy drift per row.

1D: the vibrating string (16 elements, 4 particles per element, t to 1e5 steps), critical
step 2 / w_max of the particle discretisation (``Scene.critical_dt``; Eq. 2.4 for linear
elements with lumped mass).  2D: the manufactured solution's square without its body force
(a Neo-Hookean square vibrating freely between roller walls, G = 1e-3, 16 x 16 cells, 2
particles per cell and axis, 1e4 steps), critical step the CFL limit h / c_p.  A row
*gains* energy when its total energy at the end exceeds the start by more than 1e-3 of the
energy in motion.  ``--stress-update`` picks the 1D law (default the study's forward-Euler
update; ``study-exact`` integrates it exactly and records the stored energy W(F) V0 instead
of the path work).  ``--integrator rk4`` runs the 1D musl rows with the Runge-Kutta
integrator (with an exactly integrated law; the affine rows are skipped: rk4 takes musl
only), ``--integrator midpoint`` every row; ``--transfer`` picks rows by transfer.  Writes
a Markdown table (stdout) and, with ``--json``, the records::

    python benchmarks/stability_audit.py --json docs/stability_audit.json
    python benchmarks/stability_audit.py --only 1d --stress-update study-exact \
        --json docs/stability_audit_exact.json
    python benchmarks/stability_audit.py --only 1d --stress-update study-exact \
        --integrator rk4 --json docs/stability_audit_rk4.json
    python benchmarks/stability_audit.py --stress-update study-exact --integrator midpoint \
        --transfer apic mls-mpm --json docs/stability_audit_midpoint_affine.json
"""
import argparse
import dataclasses
import json
import sys
import time

import numpy as np

PLACEMENTS = ("study", "centered", "gauss")
ROWS_1D = [("linear", "lumped", "musl"), ("linear", "lumped", "apic"),
           ("linear", "consistent", "musl"), ("bspline2", "lumped", "musl"),
           ("bspline2", "consistent", "musl"), ("bspline3", "lumped", "musl"),
           ("bspline3", "consistent", "musl"), ("lagrange2", "consistent", "musl"),
           ("uniform-bspline2", "lumped", "musl"), ("uniform-bspline2", "lumped", "apic")]
ROWS_2D = [("linear", "musl"), ("linear", "apic"), ("bspline2", "musl"), ("bspline3", "musl"),
           ("uniform-bspline2", "musl"), ("uniform-bspline2", "apic"),
           ("uniform-bspline2", "mls-mpm"), ("uniform-bspline3", "apic")]
FACTORS = (0.5, 0.9)
GAIN = 1e-3


def _drift(energies):
    total = energies["total"]
    scale = float(np.max(energies["kinetic"] + np.abs(energies["strain"])))
    return (float(np.max(np.abs(total - total[0])) / scale),
            float((total[-1] - total[0]) / scale))


def audit_1d(steps, progress, stress_update="study", pic_fraction=0.0, projection="standard",
             integrator="euler-cromer", transfers=None, factors=FACTORS, bases=None):
    from timpm.model import pic_applies
    from timpm.problems import get_problem

    problem = get_problem("vibrating-string")
    rows = []
    for basis, mass, transfer in ROWS_1D:
        if (integrator == "rk4" and transfer != "musl") or transfer not in (transfers or
                                                                           (transfer,)):
            continue
        if basis not in (bases or (basis,)):
            continue
        pic = pic_fraction if pic_applies(transfer, mass) else 0.0
        proj = projection if transfer == "musl" else "standard"  # mls: a musl projection
        for placement in PLACEMENTS:
            base = problem.scene(elements=16, ppc=4, basis=basis, mass=mass,
                                 placement=placement, transfer=transfer, dt=1e-9,
                                 stress_update=stress_update, pic_fraction=pic,
                                 projection=proj, integrator=integrator)
            critical = base.critical_dt
            for factor in factors:
                scene = problem.scene(elements=16, ppc=4, basis=basis, mass=mass,
                                      placement=placement, transfer=transfer,
                                      dt=factor * critical, stress_update=stress_update,
                                      pic_fraction=pic, projection=proj,
                                      integrator=integrator)
                rows.append(_run(scene, steps, progress, dim=1, basis=basis, mass=mass,
                                 transfer=transfer, placement=placement, factor=factor,
                                 critical_dt=critical, stress_update=stress_update,
                                 pic_fraction=pic, projection=proj, integrator=integrator))
    return rows


def audit_2d(steps, progress, integrator="euler-cromer", transfers=None, factors=FACTORS,
             bases=None):
    from timpm.model import CRITICAL_STEP_FACTOR
    from timpm.problems import get_problem

    problem = get_problem("mms-2d", G=1e-3)
    rows = []
    for basis, transfer in ROWS_2D:
        if (integrator == "rk4" and transfer != "musl") or transfer not in (transfers or
                                                                           (transfer,)):
            continue
        if basis not in (bases or (basis,)):
            continue
        for placement in PLACEMENTS:
            scene = problem.scene(elements=16, basis=basis, transfer=transfer,
                                  placement=placement, projection="standard",
                                  integrator="euler-cromer", mass="lumped")
            model = dataclasses.replace(scene.model, body_force=None, integrator=integrator)
            critical = (model.h / problem.material_law.wave_speed
                        * CRITICAL_STEP_FACTOR[integrator])
            for factor in factors:
                rows.append(_run(dataclasses.replace(model, dt=factor * critical), steps,
                                 progress, dim=2, basis=basis, mass="lumped",
                                 transfer=transfer, placement=placement, factor=factor,
                                 critical_dt=critical, integrator=integrator))
    return rows


def _run(scene, steps, progress, **row):
    """One row: ``steps`` fused serial steps of ``scene`` without the energy and volume
    guards, the energy's drift and change (or where it stopped) added to ``row``."""
    from timpm import SimulationError, Solver

    solver = Solver(scene, mode="serial", energy_guard=None,
                    record_every=max(1, steps // 1000), volume_range=None)
    row["steps"] = steps
    t0 = time.perf_counter()
    try:
        solver.run(n_steps=steps)
        row["drift"], row["change"] = _drift(solver.energies())
        row["status"] = "gains" if row["change"] > GAIN else "ok"
    except SimulationError as err:
        row.update(drift=None, change=None, status=f"stopped: {str(err)[:60]}")
    row["seconds"] = time.perf_counter() - t0
    solver.release()
    progress(row)
    return row


def table(rows) -> str:
    lines = ["| dim | basis | mass | transfer | placement | dt / critical | drift | "
             "end - start | verdict |", "|---|---|---|---|---|---:|---:|---:|---|"]
    for r in rows:
        drift = "-" if r["drift"] is None else f"{r['drift']:.2e}"
        change = "-" if r["change"] is None else f"{r['change']:+.2e}"
        lines.append(f"| {r['dim']}D | {r['basis']} | {r['mass']} | {r['transfer']} | "
                     f"{r['placement']} | {r['factor']} | {drift} | {change} | {r['status']} |")
    return "\n".join(lines)


def grouped_table(rows, factors=FACTORS) -> str:
    """One line per scheme, one column per placement and dt / critical: the change of total
    energy over the run in units of the energy in motion (+: gained), or the step at which
    the run stopped."""
    columns = [(p, f) for p in PLACEMENTS for f in factors]
    head = "| dim | basis, mass, transfer | " + " | ".join(f"{p} {f}" for p, f in columns) + " |"
    lines = [head, "|---|---|" + "---:|" * len(columns)]
    groups = {}
    for r in rows:
        groups.setdefault((r["dim"], r["basis"], r["mass"], r["transfer"]), {})[
            r["placement"], r["factor"]] = r
    for (dim, basis, mass, transfer), cells in groups.items():
        out = []
        for key in columns:
            r = cells.get(key)
            if r is None:
                out.append("")
            elif r["change"] is None:
                out.append("stop " + r["status"].split("step ")[1].split(" ")[0])
            else:
                mark = "**" if r["status"] == "gains" else ""
                out.append(f"{mark}{r['change']:+.3f}{mark}")
        lines.append(f"| {dim}D | {basis}, {mass}, {transfer} | " + " | ".join(out) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps-1d", type=int, default=100_000)
    ap.add_argument("--steps-2d", type=int, default=10_000)
    ap.add_argument("--only", choices=("1d", "2d"))
    ap.add_argument("--stress-update", default="study",
                    choices=("study", "small", "study-exact", "small-exact"),
                    help="the 1D law (default: the study's forward-Euler update)")
    ap.add_argument("--pic-fraction", type=float, default=0.0,
                    help="1D: the PIC share of the lumped MUSL rows' velocity update "
                         "(default 0, the study's FLIP)")
    ap.add_argument("--projection", default="standard", choices=("standard", "mls"),
                    help="1D: the musl rows' projection (mls: forces at Gauss points)")
    ap.add_argument("--integrator", default="euler-cromer",
                    choices=("euler-cromer", "rk4", "midpoint"),
                    help="the time integration (rk4: the musl rows; rk4 and midpoint in "
                         "1D with an exact law; the critical step times the method's factor)")
    ap.add_argument("--transfer", nargs="+", choices=("musl", "apic", "mls-mpm"),
                    help="only the rows of these transfers")
    ap.add_argument("--basis", nargs="+", help="only the rows of these bases")
    ap.add_argument("--factors", nargs="+", type=float, default=list(FACTORS),
                    help="the time steps as fractions of the critical one (default 0.5 0.9)")
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    factors = tuple(args.factors)

    def progress(r):
        print(f"{r['dim']}D {r['basis']:17s} {r['mass']:10s} {r['transfer']:7s} "
              f"{r['placement']:8s} {r['factor']}: {r['status']} "
              f"({r['change'] if r['change'] is not None else '-'})", file=sys.stderr,
              flush=True)

    rows = []
    if args.only in (None, "1d"):
        rows += audit_1d(args.steps_1d, progress, args.stress_update, args.pic_fraction,
                         args.projection, args.integrator, args.transfer, factors, args.basis)
    if args.only in (None, "2d"):
        rows += audit_2d(args.steps_2d, progress, args.integrator, args.transfer, factors,
                         args.basis)
    print(table(rows))
    print()
    print(grouped_table(rows, factors))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"date": time.strftime("%Y-%m-%d"), "gain_threshold": GAIN,
                       "command": "python benchmarks/stability_audit.py "
                                  + " ".join(argv or sys.argv[1:]), "rows": rows}, fh,
                      indent=1)
    gains = sum(r["status"] != "ok" for r in rows)
    print(f"\n{gains} of {len(rows)} rows gain energy or stop", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
