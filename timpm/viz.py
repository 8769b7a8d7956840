"""Plots: convergence (like the study's Figures 3.2, 3.6, 3.12) and particle time series
with the exact solution beside them (like Figures 3.3-3.4, 3.7-3.10)."""
import numpy as np

__all__ = ["plot_convergence", "plot_series"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path):
    """Lay out, write to ``path`` (PNG at 120 dpi) and close a figure; returns ``path``."""
    plt = _pyplot()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
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
