"""How fast can mpm88's algorithm run in Taichi's scalar CPU code?

A minimal mpm88 substep (the same P2G, grid and G2P as Taichi's example, quadratic
B-spline, float32, 128^2 grid) written with the fewest operations: no atomics (each
thread adds into its own grid copy, summed in the grid pass), no checks, no diagnostics,
no padding; run both as one plain kernel per substep and as many substeps per launch (on
one thread all in one serial task, on more a team: each thread whole substeps on its
block of particles and nodes, spin barriers between the passes), the faster counting.
Its particle-substeps per second are the ceiling that any Taichi code of this algorithm
reaches on this machine; Taichi's mpm88 (the better of pinned and unpinned workers on two
threads) and timpm's mpm88 physics (`harness.bench._mpm88_timpm`, in the mode timpm picks:
fused on one thread, a team on more) run in the same run beside it.

    python benchmarks/mpm88_ceiling.py [--threads 1] [--rounds 3] [--sizes 8192 131072]

The minimal kernel and timpm each run in a fresh process per round, the two alternating;
the fastest of each counts (one process each gave 77-102 % from run to run on this shared
machine).
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))


def ceiling(n_particles, threads=1, seconds=1.0):
    """Best Mpss of the minimal step, and how it ran: one launch per substep (three loops),
    or many substeps per launch (one thread: every loop serial; more: a team, each thread a
    block of particles and nodes, spin barriers between the passes)."""
    import taichi as ti

    ti.init(arch=ti.cpu, default_fp=ti.f32, cpu_max_num_threads=threads, log_level=ti.WARN)
    if threads > 1:
        from timpm.platform.runtime import pin_workers

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
    # one grid copy per thread; Taichi's CPU range-for gives thread c the iterations
    # [c B, (c + 1) B) with B = max(ceil(N / threads), 512)
    copies = max(1, threads)
    block = max(-(-n_particles // copies), 512)
    node_block = -(-n_grid * n_grid // copies)
    copy_v = ti.Vector.field(2, float, (copies, n_grid, n_grid))
    copy_m = ti.field(float, (copies, n_grid, n_grid))
    arrived = ti.field(ti.i32, ())
    gave_up = ti.field(ti.i32, ())

    @ti.func
    def p2g(p, c):
        # mpm88's P2G with plain adds into grid copy c
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

    @ti.func
    def grid(i, j):
        # sum and clear the copies, v = P / m, gravity, walls
        m = 0.0
        P = ti.Vector([0.0, 0.0])
        for c in ti.static(range(copies)):
            m += copy_m[c, i, j]
            P += copy_v[c, i, j]
            copy_m[c, i, j] = 0.0
            copy_v[c, i, j] = [0.0, 0.0]
        if m > 0:
            P /= m
        P.y -= dt * gravity
        if i < bound and P.x < 0:
            P.x = 0
        if i > n_grid - bound and P.x > 0:
            P.x = 0
        if j < bound and P.y < 0:
            P.y = 0
        if j > n_grid - bound and P.y > 0:
            P.y = 0
        grid_v[i, j] = P

    @ti.func
    def g2p(p):
        # mpm88's G2P
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

    @ti.kernel
    def substep():
        if ti.static(copies == 1):
            ti.loop_config(serialize=True)
            for p in range(n_particles):
                p2g(p, 0)
        else:
            for q in range(copies * block):
                if q < n_particles:
                    p2g(q, q // block)
        for i, j in grid_v:
            grid(i, j)
        for p in range(n_particles):
            g2p(p)

    @ti.func
    def barrier(target):
        # arrive, spin until every thread has; give up after 2^29 spins (a missing thread)
        ti.atomic_add(arrived[None], 1)
        spins = 0
        while ti.atomic_add(arrived[None], 0) < target:
            spins += 1
            if spins > (1 << 29):
                gave_up[None] = 1
                break

    @ti.kernel
    def many(n_steps: ti.i32):
        arrived[None] = 0
        for q in range(copies * block):
            if q % block == 0:  # thread c = q // block runs whole substeps on its block
                c = q // block
                first, end = c * block, ti.min((c + 1) * block, n_particles)
                target = 0
                for _ in range(n_steps):
                    for p in range(first, end):
                        p2g(p, c)
                    target += copies
                    barrier(target)
                    for f in range(c * node_block, ti.min((c + 1) * node_block, n_grid * n_grid)):
                        grid(f // n_grid, f % n_grid)
                    target += copies
                    barrier(target)
                    for p in range(first, end):
                        g2p(p)

    from harness.numpy_mpm import mpm88_initial

    x0, v0, *_ = mpm88_initial(n_particles)
    steps = max(10, int(seconds * 2e7 / n_particles))
    variants = {"one launch per substep": lambda: [substep() for _ in range(steps)],
                "many substeps per launch": lambda: many(steps)}
    best = {}
    for name, run in variants.items():
        x.from_numpy(x0.astype("float32"))
        v.from_numpy(v0.astype("float32"))
        J.fill(1.0)
        C.fill(0.0)
        run()  # compiles
        ti.sync()
        best[name] = 0.0
        for _ in range(3):
            t0 = time.perf_counter()
            run()
            ti.sync()
            best[name] = max(best[name], n_particles * steps / (time.perf_counter() - t0) / 1e6)
    if gave_up[None]:
        raise RuntimeError("a thread of the team never reached its barrier")
    return max(best.items(), key=lambda kv: kv[1])


def timpm_rate(n_particles, threads):
    """timpm's mpm88 physics, f32, its best scatter strategy for this thread count."""
    import timpm
    from harness.bench import _mpm88_timpm

    timpm.init(threads=threads, precision="f32")
    strategies = ["fused"] if threads == 1 else ["team"]  # what mode="auto" runs
    runs = _mpm88_timpm([n_particles], strategies, threads, "f32")["runs"]
    return strategies[0], max(r["mpss"] for r in runs)


def _in_subprocess(kind, n, threads):
    out = subprocess.run([sys.executable, __file__, "--worker", kind, str(n), str(threads)],
                         capture_output=True, text=True, check=True).stdout
    name, rate = json.loads(out.strip().splitlines()[-1])
    return name, float(rate)


def main():
    from harness.mpm88 import run_mpm88

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=3,
                    help="fresh processes of the minimal kernel and of timpm, alternating; "
                         "the fastest of each (default 3: the machine is shared and noisy)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[8192, 131072])
    args = ap.parse_args()
    threads = args.threads
    for n in args.sizes:
        pins = (False, True) if threads > 1 else (False,)
        mpm88 = max(run_mpm88(n, frames=8, threads=threads, pin=pin)["mpss"] for pin in pins)
        top, ours, ratios = (None, 0.0), (None, 0.0), []
        for _ in range(max(1, args.rounds)):
            ceiling_run = _in_subprocess("ceiling", n, threads)
            timpm_run = _in_subprocess("timpm", n, threads)
            ratios.append(timpm_run[1] / ceiling_run[1])
            top = max(top, ceiling_run, key=lambda r: r[1])
            ours = max(ours, timpm_run, key=lambda r: r[1])
        (how, top), (mode, ours) = top, ours
        print(f"{n:7d} particles, {threads} thread(s): mpm88 {mpm88:6.2f} Mpss, minimal "
              f"plain-add kernel {top:6.2f} ({top / mpm88:.1f}x; best: {how}), timpm ({mode}) "
              f"{ours:6.2f} ({ours / mpm88:.1f}x, {ours / top:.0%} of the minimal kernel; "
              f"fastest of {len(ratios)} alternating rounds, each round's ratio "
              f"{', '.join(f'{r:.0%}' for r in ratios)})")


if __name__ == "__main__":
    if len(sys.argv) > 4 and sys.argv[1] == "--worker":
        kind, n, threads = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
        os.environ["TI_CPU_MAX_NUM_THREADS"] = str(threads)
        print(json.dumps(ceiling(n, threads) if kind == "ceiling" else timpm_rate(n, threads)))
    else:
        main()
