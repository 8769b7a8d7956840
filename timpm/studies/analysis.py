"""Error measures, convergence rates and energy diagnostics."""
import numpy as np

__all__ = ["rms_error", "observed_rates", "energy_drift", "stretched_quadrature_error"]


def rms_error(u_numerical, u_exact) -> float:
    """The study's RMS error (3.2): sqrt(sum_p |u_h(x_p) - u(x_p)|^2 / n_p), one value
    (1D) or one vector (n_p, dim) per particle."""
    d = np.asarray(u_numerical, dtype=float) - np.asarray(u_exact, dtype=float)
    d = d.reshape(len(d), -1)
    return float(np.sqrt(np.mean(np.sum(d ** 2, axis=1))))


def observed_rates(elements, errors):
    """Rates between successive refinements: log(e1 / e2) / log(n2 / n1).

    For doubled element counts this is the study's log2(e(h) / e(h/2)) (Table 3.2).
    """
    rows = []
    for (n1, e1), (n2, e2) in zip(zip(elements, errors), zip(elements[1:], errors[1:])):
        ratio = e1 / e2 if e2 > 0 else float("inf")
        rate = float(np.log(ratio) / np.log(n2 / n1)) if e2 > 0 and e1 > 0 else float("nan")
        rows.append({"from": int(n1), "to": int(n2), "ratio": float(ratio), "rate": rate})
    return rows


def energy_drift(energies: dict) -> float:
    """max_t |E(t) - E(0)| / max_t (kinetic + strain), with E = kinetic + strain +
    gravity - external work: the change of total energy relative to the energy in motion."""
    total = energies["total"]
    scale = float(np.max(energies["kinetic"] + np.abs(energies["strain"])))
    if scale == 0.0:
        return 0.0
    return float(np.max(np.abs(total - total[0])) / scale)


def stretched_quadrature_error(basis, strain, n_elements=256, ppc=2) -> float:
    """The particle quadrature's error under a uniform stretch: the RMS over the interior
    nodes of f_i = sum_p V_p dphi_i(x_p), the internal force of a unit constant stress
    (exact value 0), on ``ppc`` Gauss particles per element moved by ``strain`` from
    their reference cells (element units; nodes within 4 of the body's ends left out);
    ``basis`` the class."""
    from ..bases import evaluate

    points, weights = np.polynomial.legendre.leggauss(ppc)
    X = (np.arange(n_elements)[:, None] + (points[None, :] + 1.0) / 2.0).ravel()
    x = (1.0 + strain) * X
    inside = x < n_elements
    _, dphi = evaluate(basis, x[inside], n_elements)
    force = (np.tile(weights / 2.0, n_elements)[inside] * (1.0 + strain)) @ dphi
    last = int(x[inside].max()) - 4
    return float(np.sqrt(np.mean(force[4:last] ** 2)))
