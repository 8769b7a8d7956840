"""Plots: convergence (like the study's Figures 3.2, 3.6, 3.12) and particle time series
with the exact solution beside them (like Figures 3.3-3.4, 3.7-3.10), the ULFEM
comparison, displacement fields, speed against error, and the demos' diagnostics.

The data come in as arguments (records, documents, demo results); the few reference
curves the plots draw are imported from the layers below (scenarios, studies)."""
import os

import numpy as np

from ..platform.files import replacing

__all__ = ["plot_convergence", "plot_series", "plot_comparison", "plot_fields", "plot_demo",
           "plot_runout", "plot_speed_error"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path):
    """Lay out, write to ``path`` (PNG at 120 dpi, or the format its suffix names) and close
    a figure; returns ``path``.  Written under a temporary name, then renamed: a file on
    disk is whole."""
    plt = _pyplot()
    fig.tight_layout()
    suffix = os.path.splitext(str(path))[1].lstrip(".").lower()
    try:
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=120, format=suffix or "png")
    finally:
        plt.close(fig)
    return path


def plot_convergence(docs, path, title=None):
    """RMS error against the number of elements, one line per convergence document."""
    plt = _pyplot()
    if isinstance(docs, dict):
        docs = [docs]
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for doc in docs:
        runs = [r for r in doc["runs"] if r["rms_error"] is not None]
        n = np.array([r["elements"] for r in runs], dtype=float)
        e = np.array([r["rms_error"] for r in runs])
        r0 = runs[0]
        label = doc.get("label") or f"{r0['basis']}, {r0['ppc']} PPC, {r0['mass']}"
        ax.loglog(n, e, "o-", label=label)
        crossed = [r["grid_crossings"] > 0 for r in runs]
        if any(crossed):
            ax.loglog(n[crossed], e[crossed], "x", color="k", ms=9)
    if docs and len(docs[0]["runs"]) > 1:
        runs = docs[0]["runs"]
        n0, e0 = runs[0]["elements"], runs[0]["rms_error"]
        nn = np.array([runs[0]["elements"], runs[-1]["elements"]], dtype=float)
        ax.loglog(nn, e0 * (nn / n0) ** -2.0, "k:", lw=1, label="slope -2")
    ax.set_xlabel("number of elements")
    ax.set_ylabel("RMS displacement error [m]")
    r0 = docs[0]["runs"][0]
    ax.set_title(title or f"{r0['problem']}: t = {r0['t_end']:g} s, dt = {r0['dt']:g} s"
                 + ("  (x: grid crossing)" if any(r["grid_crossings"] for d in docs for r in d["runs"]) else ""))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return save(fig, path)


def plot_series(result, path, title=None):
    """Displacement and velocity of the monitored particle against time, exact beside."""
    plt = _pyplot()
    s, rec = result.series, result.record
    fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for ax, key, label in ((axes[0], "u", "displacement [m]"), (axes[1], "v", "velocity [m/s]")):
        ax.plot(s["t"], s[key], "-", lw=1.2, label="MPM")
        if f"{key}_exact" in s:
            ax.plot(s["t"], s[f"{key}_exact"], "--", lw=1.2, label="exact")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best")
    axes[1].set_xlabel("time [s]")
    axes[0].set_title(title or (
        f"{rec['problem']}: particle {s['particle']} (x0 = {s['x0']:.4g} m)\n{rec['elements']} "
        f"elements, {rec['ppc']} PPC, {rec['basis']}, dt = {rec['dt']:g} s, "
        f"{rec['grid_crossings']} grid crossings"),
        fontsize=9)
    return save(fig, path)


def plot_comparison(cmp, path):
    """Positions of the y = 0.5 m point from MPM and ULFEM (like the study's Figure A.2)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for key, style in (("mpm", "-"), ("ulfem", "--")):
        c = cmp[key]
        ax.plot(c["t"], c["position"], style, lw=1.2,
                label=f"{key.upper()}: period {c['period']:.4f} s")
    rec = cmp["mpm"]["record"]
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position of the point at y0 = 0.5 m [m]")
    ax.set_title(f"A.5 column: {rec['elements']} elements, {rec['ppc']} PPC ({rec['basis']}), "
                 f"dt = {rec['dt']:g} s", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return save(fig, path)


def plot_fields(fields, path):
    """u_h(x) of each variant against the exact displacement, and the error below."""
    plt = _pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    x, exact = fields["x"], fields["exact"]
    top.plot(x, exact, "k--", lw=1.2, label="exact")
    for label, u in fields["fields"].items():
        top.plot(x, u, lw=1.2, label=label)
        bottom.plot(x, u - exact, lw=1.2, label=label)
    h = x[-1] / fields["elements"]
    for ax in (top, bottom):
        for k in range(fields["elements"] + 1):
            ax.axvline(k * h, color="0.85", lw=0.8, zorder=0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    top.set_ylabel("u_h(x) [m]")
    bottom.set_ylabel("u_h(x) - u(x) [m]")
    bottom.set_xlabel("x [m]")
    top.set_title(f"{fields['problem']}: {fields['elements']} elements, t = {fields['t']:g} s "
                  "(study Figures 5.5, 5.6)", fontsize=9)
    return save(fig, path)


def plot_demo(result, path):
    """The diagnostic of a demo run: energies (disks), surge front against Martin & Moyce
    (dam break), run-out and height against time with the final run-outs of Lube et al.
    and Lajeunesse et al. (column collapse)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    s = result.series
    if result.name == "disks":
        e = result.solver.energies()
        total = e["kinetic"] + e["strain"]
        for key, values in (("kinetic", e["kinetic"]), ("strain", e["strain"]), ("total", total)):
            ax.plot(e["t"], values, lw=1.4, label=key)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("energy [J/m]")
        ax.set_title(f"disks: {result.particles} particles, {result.solver.transfer}; total at the end "
                     f"{100 * total[-1] / total[0]:.1f}% of the initial", fontsize=9)
    elif result.name == "dam-break":
        from ..scenarios.demos import MARTIN_MOYCE_N2_2

        ax.plot(s["T"], s["Z"], "-", lw=1.4, label="timpm (MPM, weakly compressible)")
        ax.plot(*MARTIN_MOYCE_N2_2.T, "ko", ms=4, label="Martin & Moyce (1952), n$^2$ = 2")
        ax.set_xlabel("T = t sqrt(2 g / a)")
        ax.set_ylabel("Z = x / a (surge front)")
        ax.set_title(f"dam break: {result.particles} particles, mean |difference| "
                     f"{result.summary['mean_abs_difference']:.3f}", fontsize=9)
    else:
        m = result.summary
        L0 = m["width"]
        ax.plot(s["t"], (s["front"] - L0) / L0, lw=1.4, label="run-out (x_front - L0) / L0")
        ax.plot(s["t"], s["height"] / L0, lw=1.4, label="height H / L0")
        ax.axhline(m["lube_runout"], color="k", ls="--", lw=1,
                   label=f"final run-out, Lube et al. 2005: {m['lube_runout']:.2f}")
        ax.axhline(m["lajeunesse_runout"], color="tab:red", ls="-.", lw=1,
                   label=f"final run-out, Lajeunesse et al. 2005: {m['lajeunesse_runout']:.2f}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("length / L0 (L0: the column's width)")
        ax.set_title(f"column collapse a = {m['aspect']:g}: run-out {m['runout']:.2f}\nLube et al. "
                     f"2005: {m['lube_runout']:.2f} ({100 * m['relative_error']:+.0f}%), Lajeunesse "
                     f"et al. 2005: {m['lajeunesse_runout']:.2f} "
                     f"({100 * m['lajeunesse_relative_error']:+.0f}%)", fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="center right", bbox_to_anchor=(1.0, 0.45))
        return save(fig, path)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return save(fig, path)


def plot_runout(rows, path):
    """Run-out (L_inf - L0) / L0 against the aspect ratio, with the laws of Lube et al.
    (2005) and Lajeunesse et al. (2005)."""
    from ..scenarios.demos import lajeunesse_runout, lube_runout

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    a = np.array([r["aspect"] for r in rows])
    ax.loglog(a, [r["runout"] for r in rows], "o-", label="timpm (Drucker-Prager MPM)")
    aa = np.geomspace(min(a.min(), 0.4), max(a.max(), 8), 100)
    ax.loglog(aa, 1.2 * aa, "k--", lw=1, label="1.2 a (Lube et al. 2005, small a)")
    ax.loglog(aa, 1.9 * aa ** (2 / 3), "k:", lw=1, label="1.9 a^(2/3) (Lube et al. 2005, large a)")
    ax.loglog(aa, lube_runout(aa), color="0.6", lw=4, alpha=0.4, zorder=0, label="Lube: law used")
    ax.loglog(aa, lajeunesse_runout(aa), "-.", color="tab:red", lw=1,
              label="Lajeunesse et al. 2005: 1.8 a, 2.3 a^(2/3)")
    ax.set_xlabel("aspect ratio a = H0 / L0")
    ax.set_ylabel("run-out (L_inf - L0) / L0")
    ax.set_title("granular column collapse: timpm against Lube et al. (2005)\n"
                 "and Lajeunesse et al. (2005)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return save(fig, path)


def plot_speed_error(doc, path, title=None):
    """Log-log plot of RMS error against wall time, one colour/marker per basis/mass,
    the Pareto front as a black line, hollow markers where the time error was not
    separated, labels ``elements x PPC`` on the front."""
    from ..studies.speed_error_report import groups_by_label, is_measured

    plt = _pyplot()
    runs = [r for r in doc["runs"]
            if is_measured(r) and r["rms_error"] > 0 and r["wall_seconds"] > 0]
    groups, with_place = groups_by_label(runs)
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    markers = "osD^vP*Xh<>"
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, rs) in enumerate(groups.items()):
        rs = sorted(rs, key=lambda r: (r["ppc"], r["elements"]))
        c, m = colours[i % len(colours)], markers[i % len(markers)]
        w = np.array([r["wall_seconds"] for r in rs])
        e = np.array([r["rms_error"] for r in rs])
        sep = np.array([r.get("time_error_separated", True) for r in rs], dtype=bool)
        ax.loglog(w, e, "-", color=c, lw=0.8, alpha=0.5)
        ax.loglog(w[sep], e[sep], m, color=c, ls="none", label=label)
        if (~sep).any():
            ax.loglog(w[~sep], e[~sep], m, mfc="none", color=c, ls="none")
    front = sorted((r for r in runs if r.get("pareto")), key=lambda r: r["wall_seconds"])
    if front:
        ax.loglog([r["wall_seconds"] for r in front], [r["rms_error"] for r in front], "k-",
                  lw=1.5, alpha=0.7, zorder=0, label="Pareto front")
        for r in front:
            ax.annotate(f"{r['elements']}x{r['ppc']}", (r["wall_seconds"], r["rms_error"]),
                        textcoords="offset points", xytext=(5, 4), fontsize=7)
    if any(not r.get("time_error_separated", True) for r in runs):
        ax.plot([], [], "o", mfc="none", color="gray", ls="none", label="time error not separated")
    ax.set_xlabel("wall time of the run [s] (stepping, compilation excluded)")
    ax.set_ylabel("RMS displacement error [m]")
    ax.set_title(title or f"{doc['problem']}: error against wall time, t_end = {doc['t_end']:g} s"
                 f"\n(dt per run: halved until time error < {100 * doc['dt_tolerance']:g} % of "
                 f"the error; labels: elements x PPC)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return save(fig, path)
