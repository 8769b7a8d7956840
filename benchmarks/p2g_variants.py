"""Does P2G gain from particles sorted by cell, with the node sums of a run of particles
in one cell kept in registers and written once per run?  (A minimal mpm88 P2G, float32,
one thread, serialised: plain adds.)

    python benchmarks/p2g_variants.py [N]      # default 131072 particles

Prints ns per particle for the plain scatter and the run-accumulating one, on particles
in random and in cell order, and checks that all four give the same grid sums.  Seen on
the 2-vCPU development machine: no gain (P2G is bound by computing the 27 node values,
not by their loads and stores); see benchmarks/README.md.
"""
import sys
import time

import numpy as np
import taichi as ti

ti.init(arch=ti.cpu, default_fp=ti.f32, cpu_max_num_threads=1, log_level=ti.WARN)
n = int(sys.argv[1]) if len(sys.argv) > 1 else 131072

n_grid = 128; dx = 1 / n_grid; inv_dx = float(n_grid); dt = 2e-4
p_vol = (dx * 0.5) ** 2; p_mass = p_vol; E = 400
x = ti.Vector.field(2, float, n); v = ti.Vector.field(2, float, n)
C = ti.Matrix.field(2, 2, float, n); J = ti.field(float, n)
grid_v = ti.Vector.field(2, float, (n_grid, n_grid)); grid_m = ti.field(float, (n_grid, n_grid))

@ti.func
def node_values(p):
    Xp = x[p] * inv_dx
    base = int(Xp - 0.5)
    fx = Xp - base
    w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
    stress = -dt * 4 * E * p_vol * (J[p] - 1) / dx**2
    affine = ti.Matrix([[stress, 0], [0, stress]]) + p_mass * C[p]
    a0 = ti.Vector([affine[0, 0], affine[1, 0]]) * dx
    a1 = ti.Vector([affine[0, 1], affine[1, 1]]) * dx
    q = p_mass * v[p] - affine @ fx * dx
    vals = ti.Matrix.zero(float, 9, 3)
    for i in ti.static(range(3)):
        r = q + i * a0 if ti.static(i > 0) else q
        for j in ti.static(range(3)):
            val = r + j * a1 if ti.static(j > 0) else r
            weight = w[i].x * w[j].y
            vals[i * 3 + j, 0] = weight * p_mass
            vals[i * 3 + j, 1] = weight * val.x
            vals[i * 3 + j, 2] = weight * val.y
    return base, vals

@ti.kernel
def p2g_plain():
    ti.loop_config(serialize=True)
    for p in range(n):
        base, vals = node_values(p)
        for i, j in ti.static(ti.ndrange(3, 3)):
            I = base + ti.Vector([i, j])
            grid_m[I] += vals[i * 3 + j, 0]
            grid_v[I] += ti.Vector([vals[i * 3 + j, 1], vals[i * 3 + j, 2]])

@ti.func
def flush(cur, acc):
    for i, j in ti.static(ti.ndrange(3, 3)):
        I = cur + ti.Vector([i, j])
        grid_m[I] += acc[i * 3 + j, 0]
        grid_v[I] += ti.Vector([acc[i * 3 + j, 1], acc[i * 3 + j, 2]])

@ti.kernel
def p2g_runs():
    cur = ti.Vector([-1, -1])
    acc = ti.Matrix.zero(float, 9, 3)
    ti.loop_config(serialize=True)
    for p in range(n):
        base, vals = node_values(p)
        if (base != cur).any():
            if cur[0] >= 0:
                flush(cur, acc)
            acc = vals
            cur = base
        else:
            acc += vals
    flush(cur, acc)

@ti.kernel
def clear():
    for i, j in grid_m:
        grid_m[i, j] = 0; grid_v[i, j] = [0, 0]

rng = np.random.default_rng(0)
xs = rng.random((n, 2)) * 0.4 + 0.2
J.fill(1.0); v.from_numpy(np.tile([0, -1.0], (n, 1)).astype(np.float32))
res = {}
for label, order in [("random", np.arange(n)), ("sorted", None)]:
    xx = xs.copy()
    if order is None:
        b = np.floor(xx * inv_dx - 0.5).astype(int)
        order = np.lexsort((b[:, 1], b[:, 0]))
    x.from_numpy(xx[order].astype(np.float32))
    for name, k in [("plain", p2g_plain), ("runs", p2g_runs)]:
        clear(); k(); ti.sync()
        res[(label, name)] = (grid_m.to_numpy().sum(), *grid_v.to_numpy().sum((0, 1)))
        best = 1e9
        for r in range(5):
            t0 = time.perf_counter()
            for _ in range(20): clear(); k()
            ti.sync(); best = min(best, (time.perf_counter() - t0) / 20)
        clear(); ti.sync(); t0 = time.perf_counter()
        for _ in range(20): clear()
        ti.sync(); tc = (time.perf_counter() - t0) / 20
        print(f"{label:7s} {name:6s}: {(best - tc) * 1e9 / n:.1f} ns/particle")
sums = np.array(list(res.values()), dtype=np.float64)
assert np.allclose(sums, sums[0], rtol=1e-5), res  # the same grid, in any order
print("grid sums agree:", sums[0])
