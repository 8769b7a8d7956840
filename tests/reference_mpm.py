"""An independent NumPy implementation of the study's 1D algorithm (2.2.4, linear basis),
written from the equations with dense matrices, to check the Taichi kernels against."""
import numpy as np


def reference_run(x, vol, v, rho, E, h, n_elements, fixed, dt, n_steps, mass="lumped",
                  gravity=0.0, stress_update="study"):
    x, vol, v = x.astype(float).copy(), vol.astype(float).copy(), v.astype(float).copy()
    mp = rho * vol
    u, sig = np.zeros_like(x), np.zeros_like(x)
    nn = n_elements + 1
    free = np.setdiff1d(np.arange(nn), fixed)
    for _ in range(n_steps):
        e = np.clip(np.floor(x / h).astype(int), 0, n_elements - 1)
        xi = x / h - e
        N = np.zeros((len(x), nn))
        B = np.zeros((len(x), nn))
        rows = np.arange(len(x))
        N[rows, e], N[rows, e + 1] = 1 - xi, xi
        B[rows, e], B[rows, e + 1] = -1 / h, 1 / h
        if mass == "lumped":
            M = np.diag(N.T @ mp)
        else:
            M = (N * mp[:, None]).T @ N
        F = N.T @ (mp * gravity) - B.T @ (sig * vol)

        def solve(rhs):
            out = np.zeros(nn)
            out[free] = np.linalg.solve(M[np.ix_(free, free)], rhs[free])
            return out

        a = solve(F)
        v = v + dt * N @ a
        vn = solve(N.T @ (mp * v))
        du = vn * dt
        dup, deps = N @ du, B @ du
        u, x = u + dup, x + dup
        if stress_update.endswith("-exact"):
            # the rate law integrated exactly over the step, F_new = (1 + deps) F_old
            if stress_update == "study-exact":
                sig = E - (E - sig) / (1 + deps)
            else:
                sig = sig + E * np.log1p(deps)
        else:
            sig = sig + ((E - sig) if stress_update == "study" else E) * deps
        vol = vol * (1 + deps)
    return dict(x=x, u=u, v=v, stress=sig, volume=vol)
