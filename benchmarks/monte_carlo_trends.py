"""The probability of failure of the undrained slope (examples/slope_undrained_random.toml)
against the coefficient of variation of c_u and its scale of fluctuation: the trends
Griffiths & Fenton (2004) drew for a 2:1 undrained slope (issue 47).

    python benchmarks/monte_carlo_trends.py [--cells 60] [--realisations 150]
        [--covs 0.25 0.5 1 2] [--thetas inf 20 4] [--factor-ratio 1.47] [--workers 2]
        [--json docs/monte_carlo_trends.json] [--plot docs/monte_carlo_trends.png]

First the factor of safety at the mean strength, F_mean (no random field; bracket 1-3,
tolerance 0.01).  Each realisation then asks whether the slope stands at F = F_mean /
``--factor-ratio``: the mean slope's factor measured against F is the ratio (Griffiths &
Fenton's slope had a factor of 1.47 at the mean c_u).  For each coefficient of variation
V and isotropic scale of fluctuation theta (m; inf: one value of c_u a realisation, the
"single random variable", whose P_f is the lognormal's closed form Phi((ln(1 / ratio) +
s^2 / 2) / s), s^2 = ln(1 + V^2)), the Monte Carlo P_f with its Wilson 95% interval.  A
failed realisation is not run on (no run-out is asked).
"""
import argparse
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=60)
    ap.add_argument("--realisations", type=int, default=150)
    ap.add_argument("--covs", type=float, nargs="+", default=[0.25, 0.5, 1.0, 2.0])
    ap.add_argument("--thetas", type=float, nargs="+", default=[math.inf, 20.0, 4.0])
    ap.add_argument("--factor-ratio", type=float, default=1.47)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="FILE.png")
    ap.add_argument("--replot", metavar="FILE.json",
                    help="draw --plot from a record this script wrote, running nothing")
    args = ap.parse_args()
    if args.replot:
        doc = json.loads(Path(args.replot).read_text())
        plot(doc, args)
        return

    from monte_carlo_slope import closed_form, mean_slope
    from timpm.studies import monte_carlo as mc

    scene, body, det = mean_slope(args.cells, args.workers)
    F_mean = det["factor_of_safety"]
    F = F_mean / args.factor_ratio
    print(f"the slope asked to stand at F = {F:.4f}", flush=True)
    rows = []
    for theta in args.thetas:
        for V in args.covs:
            rf = replace(body.random_field, cohesion_cov=V, correlation_length=theta)
            world = replace(scene.world, bodies=(replace(body, random_field=rf),))
            t = time.perf_counter()
            rec = mc.monte_carlo(world, scene.t_end, args.realisations, factor=F,
                                 run_on=scene.t_end, workers=args.workers)
            row = {"cov": V, "theta": "inf" if math.isinf(theta) else theta,
                   "theta_over_H": "inf" if math.isinf(theta) else theta / 10.0,
                   "realisations": rec["realisations"], "failures": rec["failures"],
                   "probability_of_failure": rec["probability_of_failure"],
                   "wilson_95": rec["wilson_95"], "seconds": time.perf_counter() - t,
                   "closed_form_single_variable": closed_form(V, args.factor_ratio)}
            rows.append(row)
            lo, hi = rec["wilson_95"]
            print(f"theta = {row['theta']}, V = {V:g}: P_f = {rec['failures']}/"
                  f"{rec['realisations']} = {rec['probability_of_failure']:.3f} [{lo:.3f}, "
                  f"{hi:.3f}]; single variable {row['closed_form_single_variable']:.3f} "
                  f"({row['seconds']:.0f} s)", flush=True)
    doc = {"command": "python benchmarks/monte_carlo_trends.py " + " ".join(sys.argv[1:]),
           "date": time.strftime("%Y-%m-%d"), "h": scene.world.h,
           "particles": scene.world.model.n_particles, "factor_of_safety_mean": F_mean,
           "bracket": det["bracket"], "factor": F, "factor_ratio": args.factor_ratio,
           "rows": rows}
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1) + "\n")
    plot(doc, args)


def plot(doc, args):
    """P_f against V per scale of fluctuation, beside the closed form (``args.plot``)."""
    from monte_carlo_slope import closed_form

    if args.plot:
        rows, h = doc["rows"], doc["h"]
        import matplotlib
        import matplotlib.ticker
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np

        fig, ax = plt.subplots(figsize=(6.4, 4.2))
        ratio = doc["factor_ratio"]
        covs = sorted({r["cov"] for r in rows})
        V = np.geomspace(min(covs) / 1.5, max(covs) * 1.5, 100)
        ax.plot(V, [closed_form(v, ratio) for v in V], "k-", lw=1,
                label="single random variable (closed form)")
        for key in dict.fromkeys(r["theta"] for r in rows):
            sel = [r for r in rows if r["theta"] == key]
            x = [r["cov"] for r in sel]
            y = [r["probability_of_failure"] for r in sel]
            # (clipped at zero: the Wilson bound of P_f = 0 is 0 to rounding)
            err = [[max(0.0, r["probability_of_failure"] - r["wilson_95"][0]) for r in sel],
                   [max(0.0, r["wilson_95"][1] - r["probability_of_failure"]) for r in sel]]
            label = ("theta = inf (Monte Carlo)" if key == "inf"
                     else f"theta = {key:g} m (theta / H = {key / 10:g})")
            ax.errorbar(x, y, yerr=err, marker="o", ms=4, capsize=3, label=label,
                        ls="none" if key == "inf" else "-")
        ax.set(xscale="log", xlabel="coefficient of variation of c_u",
               ylabel="probability of failure",
               title=f"undrained 2:1 slope, F_mean / F = {ratio:g}, "
                     f"h = {h:g} m, N = {rows[0]['realisations']}")
        ax.set_xticks(covs, [f"{c:g}" for c in covs])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)


if __name__ == "__main__":
    main()
