"""Critical step of the Gauss-point internal force (``--projection mls`` beyond the study's
case, 1D) against the particle discretisation's, on the stability audit's string.

    python benchmarks/mls_critical_step.py

With the MLS projection the stress at each Gauss point is an MLS value of the particles'
stresses (quadratic spline weight; quadratic basis for B-splines of degree 2 and up, else
linear), and the internal force is integrated there.  Linearised at the initial state
(stress increment E * strain of the particle), the force is f = -K u with
K = G^T W R E B: B the particles' strain operator, R the MLS weights, W the Gauss weights
times their length, G the basis gradients at the Gauss points.  Its critical Euler-Cromer
step is 2 / sqrt(max |eig(M^-1 K)|) on the free nodes, M the lumped or consistent mass of
the particles; K is not symmetric, so the table gives the largest imaginary part too.
NumPy only: it mirrors ``engine/mls_projection.py`` (Gauss points over each element's
part of the body, the same weights and fallbacks).
"""
import numpy as np

from timpm.bases import stencils
from timpm.engine.mls_projection import GAUSS_POINTS, GAUSS_WEIGHTS
from timpm.problems import get_problem
from timpm.studies.mls import quadratic_spline

ROWS = [("linear", "lumped"), ("linear", "consistent"), ("bspline2", "lumped"),
        ("bspline2", "consistent"), ("bspline3", "lumped"), ("bspline3", "consistent")]


def mls_weights(xi, y, order):
    """The weight of each particle's stress in the MLS value at y (element units)."""
    d = xi - y
    w = quadratic_spline(d, 1.0)  # element units: r = |d|
    P = np.stack([d ** k for k in range(order + 1)], axis=1)
    A = np.einsum("p,pi,pj->ij", w, P, P)
    if order == 2 and A[0, 0] > 0 and np.linalg.det(A) > 1e-10 * A[0, 0] ** 3:
        return np.linalg.solve(A, (w[:, None] * P).T)[0]
    A, P = A[:2, :2], P[:, :2]  # the linear fit, as the kernels fall back to
    if A[0, 0] > 0 and np.linalg.det(A) > 1e-10 * A[0, 0] ** 2:
        return np.linalg.solve(A, (w[:, None] * P).T)[0]
    return w / w.sum()


def operators(scene):
    """(K of the Gauss-point force, K of the particles', consistent mass, lumped mass)."""
    grid, basis = scene.grid, scene.basis
    ne, h, s = grid.n_elements, grid.h, basis.support
    nn, E, rho = basis.n_nodes(ne), scene.material.E, scene.material.density
    xi = (scene.positions - grid.origin) / h
    half = 0.5 * scene.volume / h
    lo, hi = (xi - half).min(), (xi + half).max()
    base, w, dw = stencils(basis, xi, ne)
    N, B = np.zeros((len(xi), nn)), np.zeros((len(xi), nn))
    for a in range(s):
        np.add.at(N, (np.arange(len(xi)), base + a), w[:, a])
        np.add.at(B, (np.arange(len(xi)), base + a), dw[:, a] / h)
    G, R, W = [], [], []
    for e in range(ne):
        a, b = max(e, lo), min(e + 1, hi)
        for g, weight in zip(GAUSS_POINTS, GAUSS_WEIGHTS):
            if b <= a:
                continue
            y = a + (b - a) * g
            gb, _, gdw = stencils(basis, np.array([y]), ne)
            row = np.zeros(nn)
            row[gb[0]:gb[0] + s] = gdw[0] / h
            G.append(row), R.append(mls_weights(xi, y, 2 if s > 2 else 1))
            W.append(weight * (b - a) * h)
    G, R, W = np.array(G), np.array(R), np.array(W)
    mass = rho * scene.volume
    consistent = N.T @ (mass[:, None] * N)
    return (G.T @ (W[:, None] * (R @ (E * B))), B.T @ (E * scene.volume[:, None] * B),
            consistent, np.diag(consistent.sum(axis=1)))


def critical(K, M, free):
    lam = np.linalg.eigvals(np.linalg.solve(M[np.ix_(free, free)], K[np.ix_(free, free)]))
    return 2.0 / np.sqrt(np.abs(lam).max()), np.abs(lam.imag).max() / np.abs(lam).max()


def main():
    problem = get_problem("vibrating-string")
    print("| basis | mass | placement | particles (the run's estimate) | particles, "
          "eigenvalues | Gauss points | ratio | max imag / max abs |")
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for basis, mass in ROWS:
        for placement in ("study", "centered", "gauss"):
            scene = problem.scene(elements=16, ppc=4, basis=basis, mass=mass,
                                  placement=placement, dt=1e-9)
            K, Kp, Mc, Ml = operators(scene)
            free = np.ones(K.shape[0], dtype=bool)
            free[list(scene.fixed_nodes)] = False
            M = Mc if mass == "consistent" else Ml
            gauss, imag = critical(K, M, free)
            particles, _ = critical(Kp, M, free)
            print(f"| {basis} | {mass} | {placement} | {scene.critical_dt:.4g} | "
                  f"{particles:.4g} | {gauss:.4g} | {gauss / scene.critical_dt:.2f} | "
                  f"{imag:.1e} |")


if __name__ == "__main__":
    main()
