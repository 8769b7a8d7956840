"""How fast can mpm88's algorithm run in Taichi's scalar CPU code on one thread?

A minimal mpm88 substep (the same P2G, grid and G2P as Taichi's example, quadratic
B-spline, float32, 128^2 grid) written with the fewest operations: P2G in a serialised
loop (plain adds instead of compare-and-swap atomics), no checks, no diagnostics, no
padding.  Its particle-substeps per second are the ceiling that any Taichi code of this
algorithm reaches on this machine; timpm's mpm88 rows in docs/throughput.md are read
against it and against Taichi's mpm88 itself, measured in the same run.

    python benchmarks/mpm88_ceiling.py            # 8192 and 131072 particles, 1 thread
"""
import os
import subprocess
import sys
import time

os.environ.setdefault("TI_CPU_MAX_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))


def ceiling(n_particles, seconds=1.0):
    import taichi as ti

    ti.init(arch=ti.cpu, default_fp=ti.f32, cpu_max_num_threads=1, log_level=ti.WARN)
    n_grid, dt, E, bound, gravity = 128, 2e-4, 400.0, 3, 9.8
    dx = 1.0 / n_grid
    p_vol = (0.5 * dx) ** 2
    p_mass = p_vol  # density 1
    x = ti.Vector.field(2, float, n_particles)
    v = ti.Vector.field(2, float, n_particles)
    C = ti.Matrix.field(2, 2, float, n_particles)
    J = ti.field(float, n_particles)
    grid_v = ti.Vector.field(2, float, (n_grid, n_grid))
    grid_m = ti.field(float, (n_grid, n_grid))

    @ti.kernel
    def substep():
        for i, j in grid_m:
            grid_v[i, j] = [0, 0]
            grid_m[i, j] = 0
        # P2G (mpm88's), serialised: plain adds
        ti.loop_config(serialize=True)
        for p in range(n_particles):
            Xp = x[p] / dx
            base = int(Xp - 0.5)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            stress = -dt * 4 * E * p_vol * (J[p] - 1) / dx ** 2
            affine = ti.Matrix([[stress, 0], [0, stress]]) + p_mass * C[p]
            for i, j in ti.static(ti.ndrange(3, 3)):
                offset = ti.Vector([i, j])
                dpos = (offset - fx) * dx
                weight = w[i].x * w[j].y
                grid_v[base + offset] += weight * (p_mass * v[p] + affine @ dpos)
                grid_m[base + offset] += weight * p_mass
        # grid: v = P / m, gravity, walls
        for i, j in grid_m:
            if grid_m[i, j] > 0:
                grid_v[i, j] /= grid_m[i, j]
            grid_v[i, j].y -= dt * gravity
            if i < bound and grid_v[i, j].x < 0:
                grid_v[i, j].x = 0
            if i > n_grid - bound and grid_v[i, j].x > 0:
                grid_v[i, j].x = 0
            if j < bound and grid_v[i, j].y < 0:
                grid_v[i, j].y = 0
            if j > n_grid - bound and grid_v[i, j].y > 0:
                grid_v[i, j].y = 0
        # G2P
        for p in range(n_particles):
            Xp = x[p] / dx
            base = int(Xp - 0.5)
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(float, 2)
            new_C = ti.Matrix.zero(float, 2, 2)
            for i, j in ti.static(ti.ndrange(3, 3)):
                offset = ti.Vector([i, j])
                dpos = (offset - fx) * dx
                weight = w[i].x * w[j].y
                g_v = grid_v[base + offset]
                new_v += weight * g_v
                new_C += 4 * weight * g_v.outer_product(dpos) / dx ** 2
            v[p] = new_v
            x[p] += dt * v[p]
            J[p] *= 1 + dt * new_C.trace()
            C[p] = new_C

    from timpm.numpy_mpm import mpm88_initial

    x0, v0, *_ = mpm88_initial(n_particles)
    x.from_numpy(x0.astype("float32"))
    v.from_numpy(v0.astype("float32"))
    J.fill(1.0)
    substep()
    ti.sync()
    best = 0.0
    for _ in range(3):
        steps = max(10, int(seconds * 2e7 / n_particles))
        t0 = time.perf_counter()
        for _ in range(steps):
            substep()
        ti.sync()
        best = max(best, n_particles * steps / (time.perf_counter() - t0) / 1e6)
    return best


def main():
    from timpm.mpm88 import run_mpm88

    for n in (8192, 131072):
        mpm88 = run_mpm88(n, frames=8, threads=1)["mpss"]
        out = subprocess.run([sys.executable, __file__, "--worker", str(n)], capture_output=True,
                             text=True, check=True).stdout.split()[-1]
        print(f"{n:7d} particles, 1 thread: mpm88 {mpm88:6.2f} Mpss, minimal plain-add "
              f"kernel {float(out):6.2f} Mpss ({float(out) / mpm88:.1f}x)")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        print(ceiling(int(sys.argv[2])))
    else:
        main()
