"""The floor of the cubic B-spline with the consistent mass on mms-1d, and its cause:

    python benchmarks/mms_floor.py [--elements 32 64 128] [--amplitudes 0.0125 0.025 0.05]

Part 1: the RMS error of mms-1d (bspline3, consistent mass, Gauss particles) per amplitude
G and mesh, one thread, and at G = 0.05 on 64 elements per particles per cell.
Part 2: the same with the internal force integrated at the Gauss points from an MLS
stress (``projection="mls"``), per mesh at dt = 0.2 h / c, dt / 4 and dt / 16.
Part 3: the particle quadrature of a constant stress, f_i = sum_p V_p dphi_i(x_p) (exact
value 0), on Gauss particles stretched uniformly by a strain: its RMS over the interior
nodes of 256 elements, per basis, and the slope against the strain.
"""
import argparse

import numpy as np

import timpm
from timpm.problems import get_problem
from timpm.studies.analysis import stretched_quadrature_error
from timpm.studies.study import run_problem


def mms_error(G, elements, ppc=None, projection="standard", dt_factor=1):
    """The RMS error of mms-1d (bspline3, consistent mass) at dt = 0.2 h / c / dt_factor."""
    problem = get_problem("mms-1d", G=G)
    dt = problem.courant / elements / problem.c / dt_factor
    return run_problem("mms-1d", elements=elements, ppc=ppc, basis="bspline3",
                       mass="consistent", projection=projection, dt=dt, params={"G": G},
                       integrator="euler-cromer",
                       series=False, energies=False, reuse=False).record["rms_error"]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--elements", type=int, nargs="+", default=[32, 64, 128])
    p.add_argument("--amplitudes", type=float, nargs="+", default=[0.0125, 0.025, 0.05])
    args = p.parse_args(argv)
    timpm.init(threads=1)
    print("mms-1d, bspline3, consistent mass, RMS error at t = 0.02 s\n")
    print("| G | " + " | ".join(str(n) for n in args.elements) + " |")
    print("|---|" + "---:|" * len(args.elements))
    for G in args.amplitudes:
        row = [mms_error(G, n) for n in args.elements]
        print(f"| {G:g} | " + " | ".join(f"{e:.2e}" for e in row) + " |", flush=True)
    print("\nG = 0.05, 64 elements, per particles per cell\n")
    ppcs = [2, 4, 8]
    print("| ppc | " + " | ".join(str(k) for k in ppcs) + " |")
    print("|---|" + "---:|" * len(ppcs))
    print("| error | " + " | ".join(f"{mms_error(0.05, 64, k):.2e}" for k in ppcs) + " |")
    print("\nG = 0.05, forces at the Gauss points (projection mls), per time step\n")
    print("| dt | " + " | ".join(str(n) for n in args.elements) + " |")
    print("|---|" + "---:|" * len(args.elements))
    for factor in (1, 4, 16):
        row = [mms_error(0.05, n, projection="mls", dt_factor=factor) for n in args.elements]
        label = "0.2 h / c" + (f" / {factor}" if factor > 1 else "")
        print(f"| {label} | " + " | ".join(f"{e:.2e}" for e in row) + " |", flush=True)
    strains = [0.01, 0.02, 0.04, 0.08, 0.16]
    print("\nRMS of sum_p V_p dphi_i(x_p) (exact 0), Gauss particles stretched by the strain\n")
    print("| basis | " + " | ".join(f"{s:g}" for s in strains) + " | slope |")
    print("|---|" + "---:|" * (len(strains) + 1))
    for basis in ("linear", "bspline2", "bspline3"):
        row = [stretched_quadrature_error(timpm.get_basis(basis), s) for s in strains]
        slope = np.log(row[-1] / row[0]) / np.log(strains[-1] / strains[0])
        print(f"| {basis} | " + " | ".join(f"{e:.2e}" for e in row) + f" | {slope:.2f} |")


if __name__ == "__main__":
    raise SystemExit(main())
