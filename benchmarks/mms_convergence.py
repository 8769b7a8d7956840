"""Convergence and speed against error of the manufactured solutions in 2D (or 1D, 3D).

Every basis, transfer and projection on ``mms-2d`` (Neo-Hookean, G = 0.05 by default) over a series
of meshes: the RMS and L2 errors, the observed rates, the stepping time and the time a
user waits (compilation, the scene and the run), in one process, one after the other.
Writes a JSON record, a Markdown table on stdout and, with ``--plot``, error against
time (stepping and end to end)::

    python benchmarks/mms_convergence.py --json docs/mms_2d.json --plot docs/mms_2d.png
"""
import argparse
import json
import sys
import time

import numpy as np

#: (basis, transfer, projection): "mls" integrates the internal force at the Gauss points
#: (the problem's default with the musl transfer and a B-spline basis)
SCHEMES = (("linear", "musl", "standard"), ("linear", "apic", "standard"),
           ("bspline2", "musl", "standard"), ("bspline2", "musl", "mls"),
           ("bspline3", "musl", "standard"), ("bspline3", "musl", "mls"),
           ("uniform-bspline2", "apic", "standard"), ("uniform-bspline2", "mls-mpm", "standard"),
           ("uniform-bspline3", "apic", "standard"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="mms-2d")
    ap.add_argument("--G", type=float, default=0.05)
    ap.add_argument("--elements", type=int, nargs="+", default=[8, 16, 32, 64])
    ap.add_argument("--schemes", nargs="+", metavar="BASIS:TRANSFER[:PROJECTION]",
                    default=[":".join(s) for s in SCHEMES])
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--json")
    ap.add_argument("--plot")
    args = ap.parse_args(argv)

    import timpm
    from timpm.studies.study import run_problem

    timpm.init(threads=args.threads)
    rows = []
    for scheme in args.schemes:
        basis, transfer, projection = (scheme.split(":") + ["standard"])[:3]
        for n in args.elements:
            t0 = time.perf_counter()
            r = run_problem(args.problem, elements=n, basis=basis, transfer=transfer,
                            projection=projection, params={"G": args.G}, series=False,
                            energies=False).record
            r["end_to_end_seconds"] = time.perf_counter() - t0
            rows.append(r)
            print(f"{basis:17s} {transfer:8s} {projection:8s} {n:4d} rms {r['rms_error']:.3e} "
                  f"step {r['wall_seconds']:.2f} s, end to end {r['end_to_end_seconds']:.2f} s",
                  file=sys.stderr, flush=True)
    doc = {"problem": args.problem, "G": args.G, "elements": args.elements,
           "date": time.strftime("%Y-%m-%d"), "threads": timpm.platform.runtime.cpu_threads(),
           "command": "python benchmarks/mms_convergence.py " + " ".join(argv or sys.argv[1:]),
           "runs": rows}
    print(table(doc))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(doc, fh, indent=1)
    if args.plot:
        plot(doc, args.plot)
    return 0


def _groups(doc):
    out = {}
    for r in doc["runs"]:
        out.setdefault((r["basis"], r["transfer"], r.get("projection", "standard")),
                       []).append(r)
    return out


def table(doc) -> str:
    """Markdown: per scheme the errors per mesh, the rates, and at the finest mesh the
    stepping and end-to-end seconds."""
    els = doc["elements"]
    head = ("| basis, transfer, projection | " + " | ".join(str(n) for n in els)
            + " | rates | step [s] | end to end [s] |")
    lines = [head, "|---|" + "---:|" * len(els) + "---|---:|---:|"]
    for (basis, transfer, projection), runs in _groups(doc).items():
        errors = [r["rms_error"] for r in runs]
        rates = [np.log(a / b) / np.log(m / n) for a, b, n, m in
                 zip(errors, errors[1:], els, els[1:])]
        lines.append(f"| {basis}, {transfer}, {projection} | " + " | ".join(f"{e:.2e}" for e in errors)
                     + f" | {' '.join(f'{q:.2f}' for q in rates)} | "
                     f"{runs[-1]['wall_seconds']:.2f} | {runs[-1]['end_to_end_seconds']:.2f} |")
    return "\n".join(lines)


def plot(doc, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for (basis, transfer, projection), runs in _groups(doc).items():
        errors = [r["rms_error"] for r in runs]
        for ax, key in zip(axes, ("wall_seconds", "end_to_end_seconds")):
            ax.loglog([r[key] for r in runs], errors, "o-", label=f"{basis}, {transfer}, {projection}")
    axes[0].set_xlabel("stepping time [s]")
    axes[1].set_xlabel("end-to-end time [s] (compilation, scene, run)")
    axes[0].set_ylabel("RMS displacement error [m]")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.suptitle(f"{doc['problem']}, G = {doc['G']}: error against time "
                 f"({', '.join(map(str, doc['elements']))} elements per axis, {doc['date']})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
