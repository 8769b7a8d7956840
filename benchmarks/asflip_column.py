"""ASFLIP against APIC on the granular column collapse (the demo's scene, a = 2).

    python benchmarks/asflip_column.py [--cells 23] [--alpha 0.95] [--json F]

Per transfer (APIC, MLS-MPM, ASFLIP with the given alpha, beta_min = 0, beta_max = 1):

- the run-out (L_inf - L0) / L0 on the demo's floor (Coulomb friction tan 30 deg) against
  Lajeunesse et al.'s (2005) fit;
- the transfer's own dissipation: the same column on a frictionless floor, where the loss
  of kinetic + strain + gravity energy (the strain energy the path work sigma : d_eps V,
  which holds the plastic work) is what the transfer loses, as a share of the potential
  energy released.

Each run is the demo's scene (`timpm demo column-collapse --param transfer=...`), two
threads, to the demo's end.  Beside it, Sulsky et al.'s (1994) elastic disks colliding
(`timpm demo disks`, 32 cells, no gravity, no friction): the share of the energy each
transfer keeps to the demo's end.
"""
import argparse
import json
import sys
import time
from datetime import date


def run(transfer, params, cells, floor):
    """The demo's column with ``transfer`` on a floor of friction ``floor``: (run-out,
    Lajeunesse's, energies, wall seconds)."""
    import timpm
    from timpm.scenarios.demos import get_demo, lajeunesse_runout

    demo = get_demo("column-collapse", transfer=transfer, transfer_params=params,
                    cells_per_width=cells, floor_friction=floor)
    solver = timpm.Solver(demo.world(), energies=True)
    t0 = time.perf_counter()
    solver.run(t_end=demo.default_t_end())
    wall = time.perf_counter() - t0
    runout = (demo.front(solver.positions(), solver.h) - demo.width) / demo.width
    energies = solver.energies()
    solver.release()
    return runout, float(lajeunesse_runout(demo.aspect)), energies, wall


def disks_energy_kept(transfer, params, cells=32):
    """The share of the disks' initial energy left at the demo's end."""
    import timpm
    from timpm.scenarios.demos import get_demo

    demo = get_demo("disks", transfer=transfer, transfer_params=params, cells=cells)
    solver = timpm.Solver(demo.world(), energies=True)
    solver.run(t_end=demo.default_t_end())
    e = solver.energies()
    solver.release()
    total = e["kinetic"] + e["strain"] + e["gravity"]
    return float(total[-1] / total[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=23, help="cells across the column")
    ap.add_argument("--alpha", type=float, default=0.95)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    import timpm

    timpm.init(threads=2)
    cases = [("apic", None), ("mls-mpm", None),
             ("asflip", {"alpha": args.alpha, "beta_min": 0.0, "beta_max": 1.0})]
    rows = []
    for transfer, params in cases:
        runout, lajeunesse, _, wall = run(transfer, params, args.cells, 0.58)
        _, _, e, _ = run(transfer, params, args.cells, 0.0)
        total = e["kinetic"] + e["strain"] + e["gravity"]
        released = float(e["gravity"][0] - e["gravity"].min())
        loss = float(total[0] - total[-1])
        row = {"transfer": transfer, "params": params, "runout": runout,
               "lajeunesse_runout": lajeunesse,
               "lajeunesse_relative_error": (runout - lajeunesse) / lajeunesse,
               "slip_floor_transfer_loss": loss, "slip_floor_released": released,
               "slip_floor_loss_share": loss / released, "wall_seconds": wall,
               "disks_energy_kept": disks_energy_kept(transfer, params)}
        rows.append(row)
        print(f"{transfer:8s} run-out {runout:.3f} (Lajeunesse {lajeunesse:.3f}, "
              f"{100 * row['lajeunesse_relative_error']:+.1f} %); frictionless floor: the "
              f"transfer lost {loss:.4g} J of {released:.4g} J released "
              f"({100 * row['slip_floor_loss_share']:.2f} %); {wall:.1f} s; the disks keep "
              f"{100 * row['disks_energy_kept']:.1f} % of their energy", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"date": date.today().isoformat(), "command": " ".join(sys.argv),
                       "cells_per_width": args.cells, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
