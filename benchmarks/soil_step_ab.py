"""The Mohr-Coulomb soil step of Griffiths & Lane's scene file (examples/slope_griffiths_lane.toml,
4,800 particles at cells = 120) in this checkout or another (a ``git worktree``): the
stepping alone, 400 steps after 20 of warm-up, in ms per step and particle-steps per second.
Alternate checkouts in fresh processes and take the fastest of several:

    for i in 1 2 3; do python benchmarks/soil_step_ab.py /tmp/timpm-old;
                       python benchmarks/soil_step_ab.py .; done
"""
import sys
import time
from pathlib import Path


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    cells = int(sys.argv[2]) if len(sys.argv) > 2 else 120
    sys.path.insert(0, str(root))  # that checkout's timpm, not the installed one
    import timpm  # noqa: F401  (Taichi started by the package)
    from timpm.scenefile import load_scene
    from timpm.simulation.solver import Solver

    scene = load_scene(root / "examples" / "slope_griffiths_lane.toml",
                       overrides={"domain.cells": cells})
    solver = Solver(scene.world, energies=False)
    solver.run(n_steps=20)
    t0 = time.perf_counter()
    solver.run(n_steps=400)
    wall = time.perf_counter() - t0
    print(f"{root}: {wall / 400 * 1e3:.3f} ms/step, "
          f"{scene.world.n_particles * 400 / wall / 1e6:.2f} M particle-steps/s")


if __name__ == "__main__":
    main()
