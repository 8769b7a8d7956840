"""The undrained slope of random strength (examples/slope_undrained_random.toml) by Monte
Carlo: one value of c_u per realisation against the lognormal's closed form, then the
spatially random field beside it (issue 47).

    python benchmarks/monte_carlo_slope.py [--cells 60] [--realisations 400]
        [--cases 0.5:1.0 0.5:1.5 0.2:2.0] [--theta 20 2] [--workers 2]
        [--json docs/monte_carlo_slope.json] [--plot docs/monte_carlo_slope.png]

First the factor of safety at the mean strength (no random field; bracket 1-3, tolerance
0.01).  Then for each case V:F (coefficient of variation V, the slope asked to stand at
F): with an infinite scale of fluctuation the slope's factor is F_mean c_u / mean (phi =
0), so it fails where c_u < mean F / F_mean, with probability Phi((ln(F / F_mean) + s^2 /
2) / s), s^2 = ln(1 + V^2), evaluated at both ends of F_mean's bracket; the study's P_f
and its Wilson 95% interval beside it.  Then the same V and F with the scales of
fluctuation ``--theta`` (horizontal, vertical, m): the spatially random slope.
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


def closed_form(V, ratio):
    """P[F_mean c_u / mean < F] for a lognormal c_u of coefficient of variation V, ratio =
    F_mean / F: Phi((ln(1 / ratio) + s^2 / 2) / s), s^2 = ln(1 + V^2)."""
    s = math.sqrt(math.log1p(V * V))
    return 0.5 * (1 + math.erf((math.log(1.0 / ratio) + 0.5 * s * s) / (s * math.sqrt(2))))


def mean_slope(cells, workers):
    """Taichi started on one thread; the undrained slope's scene at ``cells``, its body and
    the factor of safety at the mean strength (no random field; bracket 1-3, tolerance
    0.01), printed."""
    import timpm
    from timpm.scenefile import load_scene
    from timpm.studies import factor_of_safety as fos

    timpm.init(threads=1)
    scene = load_scene(ROOT / "examples" / "slope_undrained_random.toml",
                       overrides={"domain.cells": cells})
    body = scene.world.bodies[0]
    mean = replace(scene.world, bodies=(replace(body, random_field=None),))
    t0 = time.perf_counter()
    det, _ = fos.factor_of_safety(mean, scene.t_end, low=1.0, high=3.0, tolerance=0.01,
                                  workers=workers)
    F_lo, F_hi = det["bracket"]
    print(f"h = {scene.world.h:g} m, {scene.world.model.n_particles} particles: F at the mean "
          f"strength {det['factor_of_safety']:.4f} [{F_lo:.4f}, {F_hi:.4f}] "
          f"({time.perf_counter() - t0:.1f} s)", flush=True)
    return scene, body, det


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", type=int, default=60)
    ap.add_argument("--realisations", type=int, default=400)
    ap.add_argument("--cases", nargs="+", default=["0.5:1.0", "0.5:1.5", "0.2:2.0"])
    ap.add_argument("--theta", type=float, nargs=2, default=(20.0, 2.0))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--plot", metavar="FILE.png")
    args = ap.parse_args()

    from timpm.studies import monte_carlo as mc

    scene, body, det = mean_slope(args.cells, args.workers)
    F_lo, F_hi = det["bracket"]
    rows = []
    for case in args.cases:
        V, F = (float(v) for v in case.split(":"))
        closed = [closed_form(V, Fm / F) for Fm in (F_hi, F_lo)]
        for theta in (math.inf, tuple(args.theta)):
            rf = replace(body.random_field, cohesion_cov=V, correlation_length=theta)
            world = replace(scene.world, bodies=(replace(body, random_field=rf),))
            t = time.perf_counter()
            rec = mc.monte_carlo(world, scene.t_end, args.realisations, factor=F,
                                 workers=args.workers)
            row = {"cov": V, "factor": F, "theta": "inf" if theta == math.inf else list(theta),
                   "realisations": rec["realisations"], "failures": rec["failures"],
                   "probability_of_failure": rec["probability_of_failure"],
                   "wilson_95": rec["wilson_95"], "seconds": time.perf_counter() - t,
                   "convergence": rec["convergence"]}
            if theta == math.inf:
                row["closed_form"] = closed
                row["agrees"] = rec["wilson_95"][0] <= closed[1] and closed[0] <= \
                    rec["wilson_95"][1]
            rows.append(row)
            lo, hi = rec["wilson_95"]
            print(f"V = {V:g}, F = {F:g}, theta = {row['theta']}: P_f = {rec['failures']}/"
                  f"{rec['realisations']} = {rec['probability_of_failure']:.4f} [{lo:.4f}, "
                  f"{hi:.4f}]" + (f"; closed form {closed[0]:.4f}-{closed[1]:.4f}"
                                  if theta == math.inf else "")
                  + f" ({row['seconds']:.0f} s)", flush=True)
    doc = {"command": "python benchmarks/monte_carlo_slope.py " + " ".join(sys.argv[1:]),
           "date": time.strftime("%Y-%m-%d"), "h": scene.world.h,
           "particles": scene.world.model.n_particles,
           "factor_of_safety_mean": det["factor_of_safety"], "bracket": det["bracket"],
           "rows": rows}
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1) + "\n")
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.2))
        for row in rows:
            c = list(zip(*row["convergence"]))
            label = f"V = {row['cov']:g}, F = {row['factor']:g}, theta = {row['theta']}"
            line, = ax.plot(c[0], c[1], label=label,
                            ls="-" if row["theta"] == "inf" else "--")
            if "closed_form" in row:
                ax.axhspan(*row["closed_form"], color=line.get_color(), alpha=0.2)
        ax.set(xscale="log", xlabel="realisations N", ylabel="probability of failure",
               title=f"undrained slope, h = {scene.world.h:g} m: P_f against N "
                     "(bands: the closed form)")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)


if __name__ == "__main__":
    main()
