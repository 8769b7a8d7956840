"""The throughput benchmark's baselines compute the same physics as timpm, and the
benchmark script runs (at a tiny size; timings are never asserted).  The harness lives in
benchmarks/harness, outside the package: this file puts benchmarks/ on ``sys.path``."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from timpm.problems import get_problem
from timpm.scenarios.mpm88 import mpm88_world
from timpm.simulation.solver import Solver

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from harness.mpm88 import run_mpm88  # noqa: E402
from harness.numpy_mpm import Numpy1D, mpm88_initial, mpm88_run  # noqa: E402


def test_numpy_1d_is_the_same_algorithm():
    scene = get_problem("vibrating-string").scene(elements=16, ppc=4)
    s = Solver(scene, energies=False)
    s.run(n_steps=300)
    ref = Numpy1D(scene).run(300)
    scale = np.abs(ref.u).max()
    assert scale > 1e-4  # the string moved
    np.testing.assert_allclose(s.displacements(), ref.u, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(s.stresses(), ref.sigma, rtol=0,
                               atol=1e-10 * np.abs(ref.sigma).max())


def test_numpy_mpm88_is_timpms_mpm88_physics():
    """timpm's World with the j-fluid, MLS-MPM and mpm88's walls against the NumPy step
    written from mpm88's code: the same positions and J after 60 substeps (float64)."""
    x0, v0, C0, J0 = mpm88_initial(1500, seed=3)
    world, shift = mpm88_world(x0)
    s = Solver(world, energies=False)
    s.run(n_steps=60)
    x, v, C, J = mpm88_run(x0, v0, C0, J0, 60)
    assert np.abs(x - x0).max() > 0.01  # the block fell and spread
    np.testing.assert_allclose(s.positions() + shift, x, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.read("J"), J, rtol=0, atol=1e-11)


def test_j_fluid_volume_is_j_times_the_initial_volume():
    """The j-fluid keeps V0 as mpm88 does (no determinant, no division by a volume); the
    volume reported is J V0 and the density m / (J V0), also after the splash."""
    x0 = mpm88_initial(1500, seed=3)[0]
    world, _ = mpm88_world(x0)
    s = Solver(world, energies=False)
    s.run(n_steps=1500)  # 0.3 s: the block has hit the floor
    assert not s.update_volume
    V0, J = s.read("vol"), s.read("J")
    assert np.all(V0 == V0[0]) and np.abs(J - 1.0).max() > 1e-2
    np.testing.assert_allclose(s.volumes(), J * V0, rtol=1e-12)
    np.testing.assert_allclose(s.densities() * s.volumes(), s.read("m"), rtol=1e-12)


def test_taichi_mpm88_headless_agrees_with_timpm():
    """Taichi's installed mpm88 (float32) run headless, and timpm from its initial state:
    positions agree to float32 round-off after one frame (50 substeps)."""
    r = run_mpm88(1024, frames=2, threads=1)
    assert r["dtype"] == "f32" and r["threads"] == 1 and r["mpss"] > 0
    world, shift = mpm88_world(r["x0"])
    s = Solver(world, energies=False)
    s.run(n_steps=50)
    moved = np.abs(r["x1"] - r["x0"]).max()
    assert moved > 1e-3
    assert np.abs(s.positions() + shift - r["x1"]).max() < 2e-6


@pytest.mark.slow  # the whole harness (every strategy, both precisions, mpm88 in subprocesses)
def test_bench_script_runs_tiny(tmp_path):
    from harness.bench import bench

    out = tmp_path / "tp"
    res = bench(str(out), size="tiny", threads=(1,), progress=lambda m: None)
    doc = json.loads((tmp_path / "tp.json").read_text())
    assert doc["size"] == "tiny"
    assert {r["scatter"] for r in res["timpm"]} == {"atomic", "serial", "private", "fused"}
    # every strategy and precision agrees with mpm88 from its own initial state
    for prec in ("f32", "f64"):
        assert all(d < 2e-6 for d in res["agreement"][prec].values())
    assert (tmp_path / "tp.md").read_text().startswith("# timpm throughput")
    assert (tmp_path / "tp.png").stat().st_size > 1000
