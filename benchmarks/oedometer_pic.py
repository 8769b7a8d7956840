"""The oedometer (A.4) at rest against the PIC share b of the MUSL velocity update:

    python benchmarks/oedometer_pic.py [--fractions 0 0.001 0.01 0.05 0.2 1]

For each b: the largest particle speed at t_end (the column is at rest: exact 0) and the
strain against the exact -ln(1 + p0/E), one thread.
"""
import argparse

import numpy as np

import timpm
from timpm.problems import get_problem
from timpm.simulation.solver import Solver
from timpm.studies.study import run_problem


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fractions", type=float, nargs="+", default=[0, 0.001, 0.01, 0.05, 0.2, 1])
    args = p.parse_args(argv)
    timpm.init(threads=1)
    prob = get_problem("oedometer")
    print("| b | max abs(v_p), m/s | strain | exact | strain error |")
    print("|---|---:|---:|---:|---:|")
    for b in args.fractions:
        record = run_problem("oedometer", pic_fraction=b, reuse=False).record
        solver = Solver(prob.scene(pic_fraction=b), energies=False)
        solver.run(t_end=prob.t_end)
        speed = float(np.abs(solver.velocities()).max())
        solver.release()
        print(f"| {b:g} | {speed:.2g} | {record['strain']:.6f} | {record['exact_strain']:.6f} "
              f"| {100 * record['strain_relative_error']:.3f}% |")


if __name__ == "__main__":
    raise SystemExit(main())
