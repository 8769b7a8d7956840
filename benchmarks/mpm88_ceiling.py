"""How fast can mpm88's algorithm run in Taichi's scalar CPU code?

A minimal mpm88 substep (the same P2G, grid and G2P as Taichi's example, quadratic
B-spline, float32, 128^2 grid) written with the fewest operations: no atomics (on one
thread P2G is a serialised loop, on more each thread adds into its own grid copy, summed
in the grid pass), no checks, no diagnostics, no padding, one plain kernel per substep.
Its particle-substeps per second are the ceiling that any Taichi code of this algorithm
reaches on this machine; Taichi's mpm88 (the better of pinned and unpinned workers on two
threads) and timpm's mpm88 physics (`timpm.bench._mpm88_timpm`, best scatter) run in the
same run beside it.

    python benchmarks/mpm88_ceiling.py [--threads 1]   # 8192 and 131072 particles
"""
import argparse
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))


def ceiling(n_particles, threads=1, seconds=1.0):
    import taichi as ti

    ti.init(arch=ti.cpu, default_fp=ti.f32, cpu_max_num_threads=threads, log_level=ti.WARN)
    if threads > 1:
        from timpm.runtime import pin_workers

        pin_workers()
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
    # one grid copy per thread; Taichi's CPU range-for gives thread c the iterations
    # [c B, (c + 1) B) with B = max(ceil(N / threads), 512)
    copies = max(1, threads)
    block = max(-(-n_particles // copies), 512)
    copy_v = ti.Vector.field(2, float, (copies, n_grid, n_grid))
    copy_m = ti.field(float, (copies, n_grid, n_grid))

    @ti.func
    def p2g(p, c):
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
            at = ti.Vector([c, base[0] + i, base[1] + j])
            copy_v[at] = copy_v[at] + weight * (p_mass * v[p] + affine @ dpos)
            copy_m[at] = copy_m[at] + weight * p_mass

    @ti.kernel
    def substep():
        # P2G (mpm88's) with plain adds: serialised on one thread, else into the thread's
        # grid copy
        if ti.static(copies == 1):
            ti.loop_config(serialize=True)
            for p in range(n_particles):
                p2g(p, 0)
        else:
            for q in range(copies * block):
                if q < n_particles:
                    p2g(q, q // block)
        # grid: sum and clear the copies, v = P / m, gravity, walls
        for i, j in grid_m:
            grid_m[i, j] = 0.0
            grid_v[i, j] = [0.0, 0.0]
            for c in ti.static(range(copies)):
                grid_m[i, j] += copy_m[c, i, j]
                grid_v[i, j] += copy_v[c, i, j]
                copy_m[c, i, j] = 0.0
                copy_v[c, i, j] = [0.0, 0.0]
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


def timpm_rate(n_particles, threads):
    """timpm's mpm88 physics, f32, its best scatter strategy for this thread count."""
    import timpm
    from timpm.bench import _mpm88_timpm

    timpm.init(threads=threads, precision="f32")
    strategies = ["serial"] if threads == 1 else ["private"]
    return max(r["mpss"] for r in _mpm88_timpm([n_particles], strategies, threads, "f32")["runs"])


def _in_subprocess(kind, n, threads):
    out = subprocess.run([sys.executable, __file__, "--worker", kind, str(n), str(threads)],
                         capture_output=True, text=True, check=True).stdout.split()[-1]
    return float(out)


def main():
    from timpm.mpm88 import run_mpm88

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, default=1)
    threads = ap.parse_args().threads
    for n in (8192, 131072):
        pins = (False, True) if threads > 1 else (False,)
        mpm88 = max(run_mpm88(n, frames=8, threads=threads, pin=pin)["mpss"] for pin in pins)
        top = _in_subprocess("ceiling", n, threads)
        ours = _in_subprocess("timpm", n, threads)
        print(f"{n:7d} particles, {threads} thread(s): mpm88 {mpm88:6.2f} Mpss, minimal "
              f"plain-add kernel {top:6.2f} ({top / mpm88:.1f}x), timpm {ours:6.2f} "
              f"({ours / mpm88:.1f}x, {ours / top:.0%} of the minimal kernel)")


if __name__ == "__main__":
    if len(sys.argv) > 4 and sys.argv[1] == "--worker":
        kind, n, threads = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
        os.environ["TI_CPU_MAX_NUM_THREADS"] = str(threads)
        print(ceiling(n, threads) if kind == "ceiling" else timpm_rate(n, threads))
    else:
        main()
