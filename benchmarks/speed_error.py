"""Speed against error for the study's three benchmarks with exact solutions.

Run from the repository root:

    python benchmarks/speed_error.py [--problems vibrating-string ...] [--out docs]
                                     [--repeats 3] [--threads 2] [--quick]

For each problem it sweeps basis x mass x elements at the problem's particles per element
(plus the cubic B-spline at Gauss-Legendre particle positions, whose particle quadrature
is accurate enough for its fourth order), chooses dt per run so that the time error does
not hide the spatial error (see :mod:`timpm.studies.speed_error`), and writes
``speed_error_<problem>.json`` and ``speed_error_<problem>.png`` into ``--out``, printing
the report: table, Pareto front, and for target errors the cheapest basis and mesh and its
factor over linear elements.  Each problem takes a few minutes on two cores, most of it
kernel compilation (one per run and time step tried; excluded from the wall times).

Timings are informative: they come from a possibly shared machine (minimum of
``--repeats`` runs).  Nothing here is an assertion.
"""
import argparse
import json
import os
import sys
import time

import timpm
from timpm.output.viz import plot_speed_error
from timpm.studies.speed_error import (cheapest_for, default_targets, format_report,
                                       merge_studies, speed_error_study)

ALL_COMBOS = (("linear", "lumped"), ("linear", "consistent"), ("bspline2", "lumped"),
              ("bspline2", "consistent"), ("bspline3", "lumped"), ("bspline3", "consistent"))

#: per problem: common settings and the partial sweeps merged into one report
SWEEPS = {
    "vibrating-string": dict(
        common=dict(elements=(4, 8, 16, 32, 64), ppcs=(4,), t_end=None),   # t_end 0.1 s
        parts=[dict(combos=ALL_COMBOS, placement="study"),
               dict(combos=(("bspline3", "consistent"),), placement="gauss")]),
    "soil-column": dict(
        common=dict(elements=(8, 16, 32, 64, 128), ppcs=(2,), t_end=0.2),  # Table 3.3, 2 PPC
        parts=[dict(combos=ALL_COMBOS, placement="study"),
               dict(combos=(("bspline3", "consistent"),), placement="gauss")]),
    "vibrating-bar": dict(
        common=dict(elements=(4, 8, 16, 32, 64), ppcs=(3,), t_end=None),   # t_end 1 s
        parts=[dict(combos=ALL_COMBOS, placement="study"),
               dict(combos=(("bspline3", "consistent"),), placement="gauss")]),
}
QUICK_ELEMENTS = {"vibrating-string": (4, 8, 16), "soil-column": (8, 16, 32),
                  "vibrating-bar": (4, 8, 16)}


def run_one(problem, out_dir, repeats, quick=False, targets=None, verbose=True):
    spec = SWEEPS[problem]
    common = dict(spec["common"])
    if quick:
        common["elements"] = QUICK_ELEMENTS[problem]
    say = (lambda msg: print(msg, file=sys.stderr, flush=True)) if verbose else None
    docs = [speed_error_study(problem, repeats=repeats, progress=say, **common, **part)
            for part in spec["parts"]]
    doc = merge_studies(docs)
    answers = cheapest_for(doc["runs"], targets or default_targets(doc["runs"]))
    doc["targets"] = answers
    report = format_report(doc, answers)
    doc["report"] = report
    stem = os.path.join(out_dir, f"speed_error_{problem.replace('-', '_')}")
    plot_speed_error(doc, stem + ".png")
    with open(stem + ".json", "w") as fh:
        json.dump(doc, fh, indent=2)
    print(f"\n{'=' * 100}\n{report}\nwritten: {stem}.json, {stem}.png", flush=True)
    return doc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problems", nargs="+", default=list(SWEEPS), choices=list(SWEEPS))
    ap.add_argument("--out", default="docs", help="output folder (default: docs)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per configuration")
    ap.add_argument("--threads", type=int, default=2, help="CPU threads for Taichi")
    ap.add_argument("--targets", type=float, nargs="+", help="target errors (default: decades)")
    ap.add_argument("--quick", action="store_true", help="three meshes per problem only")
    ap.add_argument("--quiet", action="store_true", help="no progress lines")
    args = ap.parse_args(argv)
    timpm.init(threads=args.threads)
    os.makedirs(args.out, exist_ok=True)
    for problem in args.problems:
        t0 = time.perf_counter()
        run_one(problem, args.out, args.repeats, args.quick, args.targets, not args.quiet)
        print(f"{problem}: {time.perf_counter() - t0:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
