"""The study's Table 3.2 as a plain NumPy user would write it: the vibrating string (3.3),
linear elements, lumped mass, 4 particles per element at (k + 1) / 5, dt = 1e-4 s to
t = 0.1 s, on 4, 8, 16, 32 and 64 elements; the RMS error against the exact solution and
its observed rates.  NumPy only: the baseline of ``benchmarks/convergence_e2e.py``.

    python benchmarks/numpy_table_3_2.py
"""
import numpy as np

E, RHO, L, V0, PPC, DT, T_END = 100.0, 1.0, 25.0, 0.1, 4, 1e-4, 0.1


def run(n_elements):
    h = L / n_elements
    local = (np.arange(PPC) + 1.0) / (PPC + 1.0)
    x = ((np.arange(n_elements)[:, None] + local[None, :]) * h).ravel()
    x0 = x.copy()
    vol = np.full(x.size, h / PPC)
    m = RHO * vol
    v = V0 * np.sin(np.pi * x / L)
    sigma, u = np.zeros_like(x), np.zeros_like(x)
    nn = n_elements + 1
    fixed = [0, nn - 1]
    for _ in range(int(round(T_END / DT))):
        # P2G: lumped mass and internal force; a = F / m; G2P of the velocity
        xi = x / h
        e = np.clip(np.floor(xi).astype(np.int64), 0, nn - 2)
        n1 = xi - e
        n0 = 1.0 - n1
        mass = np.bincount(e, m * n0, nn) + np.bincount(e + 1, m * n1, nn)
        sv = sigma * vol / h
        force = np.bincount(e, sv, nn) - np.bincount(e + 1, sv, nn)
        acc = np.where(mass > 0, force / np.where(mass > 0, mass, 1.0), 0.0)
        acc[fixed] = 0.0
        v += DT * (n0 * acc[e] + n1 * acc[e + 1])
        # P2G of the momentum, nodal velocities, G2P of displacement and strain
        mom = np.bincount(e, m * n0 * v, nn) + np.bincount(e + 1, m * n1 * v, nn)
        vel = np.where(mass > 0, mom / np.where(mass > 0, mass, 1.0), 0.0)
        vel[fixed] = 0.0
        du = DT * (n0 * vel[e] + n1 * vel[e + 1])
        deps = DT * (vel[e + 1] - vel[e]) / h
        u += du
        x += du
        sigma += (E - sigma) * deps
        vol *= 1.0 + deps
    t = round(T_END / DT) * DT
    w = np.pi * np.sqrt(E / RHO) / L
    exact = V0 / w * np.sin(w * t) * np.sin(np.pi * x0 / L)
    return np.sqrt(np.mean((u - exact) ** 2))


if __name__ == "__main__":
    meshes = (4, 8, 16, 32, 64)
    errors = [run(n) for n in meshes]
    for k, (n, err) in enumerate(zip(meshes, errors)):
        rate = np.log2(errors[k - 1] / err) if k else float("nan")
        print(f"{n:4d} {err:.4e} {rate:6.3f}")
