"""Convergence of every basis on the study's three benchmarks, with plots.

    python benchmarks/convergence_all.py [--out docs] [--quick]

Writes ``convergence_<problem>.json`` and ``.png`` into the output folder and prints one
table per problem (RMS error and observed rate per mesh, grid crossings).  Settings follow
the study: vibrating string 4 PPC, t = 0.1 s (dt = 1e-5 s here, so that the first-order
time error stays below the spatial error of the high-order runs); soil column 2 PPC,
dt = 1e-4 s, t = 0.2 s (Table 3.3, Figure 3.6); vibrating bar 3 PPC, dt = 1e-3 s, t = 1 s
(Table 3.4, Figure 3.12).
"""
import argparse
import json
import os

from timpm.output.viz import plot_convergence
from timpm.studies.study import convergence

CASES = {
    "vibrating-string": dict(elements=(4, 8, 16, 32, 64), ppc=4, dt=1e-5, t_end=0.1),
    "soil-column": dict(elements=(8, 16, 32, 64, 128), ppc=2, dt=1e-4, t_end=0.2),
    "vibrating-bar": dict(elements=(4, 8, 16, 32, 64, 128), ppc=3, dt=1e-3, t_end=1.0),
}
VARIANTS = (
    dict(basis="linear", mass="lumped"),
    dict(basis="linear", mass="lumped", projection="mls"),
    dict(basis="bspline2", mass="lumped"),
    dict(basis="bspline3", mass="lumped"),
    dict(basis="bspline2", mass="consistent", placement="gauss"),
    dict(basis="bspline3", mass="consistent", placement="gauss"),
    dict(basis="lagrange2", mass="consistent"),
)


def label(v):
    extra = [v[k] for k in ("projection", "placement") if k in v]
    return f"{v['basis']} {v['mass']}" + (f" ({', '.join(extra)})" if extra else "")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs")
    ap.add_argument("--quick", action="store_true", help="three coarsest meshes only")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for problem, case in CASES.items():
        case = dict(case)
        if args.quick:
            case["elements"] = case["elements"][:3]
        docs = []
        print(f"\n{problem}: {case}")
        for v in VARIANTS:
            try:
                doc = convergence(problem, energies=False, **case, **v)
            except Exception as exc:  # a variant that fails is reported, not hidden
                print(f"  {label(v):40s} failed: {exc}")
                continue
            doc["label"] = label(v)
            docs.append(doc)
            errs = "  ".join(f"{r['rms_error']:.2e}" for r in doc["runs"])
            rates = "  ".join(f"{r['rate']:5.2f}" for r in doc["rates"])
            cross = [r["grid_crossings"] for r in doc["runs"]]
            print(f"  {label(v):40s} e: {errs}\n  {'':40s} rates: {rates}   crossings: {cross}")
        with open(os.path.join(args.out, f"convergence_{problem}.json"), "w") as fh:
            json.dump(docs, fh, indent=1)
        plot_convergence(docs, os.path.join(args.out, f"convergence_{problem}.png"),
                         title=f"{problem}: every basis")


if __name__ == "__main__":
    main()
