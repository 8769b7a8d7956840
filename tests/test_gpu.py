"""GPU backends: the same runs as on the CPU, within round-off (atomic adds in another
order), and clear errors for what runs on the CPU only.

Skipped where Taichi finds no GPU backend (CI has none).  Each test runs a subprocess that
starts Taichi on the CPU (one thread, the reference), then on the GPU: the test session's
runtime is never restarted.  ``TIMPM_GPU_ARCH`` picks the backend (default: cuda)."""
import json
import os
import textwrap

import pytest
from conftest import run_script
from taichi.lang.misc import is_arch_supported

from timpm.platform import runtime

GPU = os.environ.get("TIMPM_GPU_ARCH", "cuda")
pytestmark = pytest.mark.skipif(
    GPU not in runtime.ARCHS or not is_arch_supported(runtime.ARCHS[GPU]),
    reason=f"no {GPU} backend on this machine")

#: seconds a subprocess may take (compilation on both backends included)
TIMEOUT = 600

PRELUDE = f'''
import json, sys
import numpy as np
import timpm
from timpm import Body, Box, World
from timpm.platform import runtime
from timpm.materials import DruckerPrager, NeoHookean
from timpm.problems import get_problem
GPU = {GPU!r}
'''


def _script(tmp_path, body):
    """Run PRELUDE + ``body`` in a new process group; its last stdout line is JSON."""
    path = tmp_path / "script.py"
    path.write_text(PRELUDE + textwrap.dedent(body))
    rc, out, err = run_script(path, dict(os.environ), TIMEOUT)
    assert rc == 0, err[-4000:]
    return json.loads(out.strip().splitlines()[-1])


def test_table_3_2_on_the_gpu(tmp_path):
    """The study's Table 3.2 (vibrating string, linear, lumped, MUSL) on the GPU: the same
    errors as on the CPU to 1e-9, second order, run by one parallel launch per step with
    atomic adds."""
    res = _script(tmp_path, '''
        from timpm.studies.study import convergence
        from timpm.simulation.solver import Solver
        out = {}
        for arch in ("cpu", GPU):
            timpm.init(threads=1, arch=arch)
            doc = convergence("vibrating-string", elements=(4, 8, 16, 32, 64))
            out[arch] = [r["rms_error"] for r in doc["runs"]]
            s = Solver(get_problem("vibrating-string").scene(elements=8))
            out[arch + "_plan"] = [s.features.arch, s.features.mode, s.features.scatter]
        print(json.dumps(out))
        ''')
    assert res[GPU + "_plan"] == [GPU, "parallel", "atomic"]
    assert res["cpu_plan"][0] == "cpu"
    cpu, gpu = res["cpu"], res[GPU]
    assert len(gpu) == 5
    for e_cpu, e_gpu in zip(cpu, gpu):
        assert abs(e_gpu - e_cpu) <= 1e-9 * e_cpu
    assert all(a / b > 3.5 for a, b in zip(gpu, gpu[1:]))  # second order: ratio ~4


SCENES = {
    # a collapsing sand column on a rough floor: plasticity, walls, MLS-MPM
    "sand-2d": '''
        sand = DruckerPrager(E=2e5, nu=0.3, density=1500.0, friction_angle=30.0)
        scene = World(domain=(1.2, 0.8), cells=24, transfer="mls-mpm",
                      bodies=[Body(Box((0.0, 0.0), (0.3, 0.6)), sand, ppc=4)],
                      walls={"bottom": "friction"}, courant=0.5)
        steps = 60
        ''',
    # an elastic block falling in 3D: quadratic B-splines, APIC
    "rubber-3d": '''
        rubber = NeoHookean(E=1e5, nu=0.3, density=1000.0)
        scene = World(domain=(1.0, 1.0, 1.0), cells=8, basis="uniform-bspline2",
                      transfer="apic", bodies=[Body(Box((0.3,) * 3, (0.6,) * 3), rubber)],
                      walls={"bottom": "sticky"})
        steps = 40
        ''',
    # the 1D bar with cubic B-splines and the consistent mass (the banded solve)
    "bar-1d-consistent": '''
        scene = get_problem("vibrating-bar").scene(elements=16, basis="bspline3",
                                                   mass="consistent")
        steps = 200
        ''',
}


@pytest.mark.parametrize("name", list(SCENES))
def test_scenes_agree_with_the_cpu(tmp_path, name):
    """Positions and velocities after the same steps on the CPU (one thread, serial adds)
    and on the GPU (atomic adds): equal to round-off; mass and momentum on the grid as on
    the CPU."""
    res = _script(tmp_path, SCENES[name] + '''
        from timpm.simulation.solver import Solver
        out = {}
        for arch in ("cpu", GPU):
            timpm.init(threads=1, arch=arch)
            s = Solver(scene, mode="parallel", energies=False)
            s.run(n_steps=steps)
            out[arch] = dict(x=s.positions().tolist(), v=s.velocities().tolist(),
                             scatter=s.features.scatter)
            s.release()
        print(json.dumps(out))
        ''')
    import numpy as np

    x_cpu, x_gpu = np.array(res["cpu"]["x"]), np.array(res[GPU]["x"])
    v_cpu, v_gpu = np.array(res["cpu"]["v"]), np.array(res[GPU]["v"])
    assert res[GPU]["scatter"] == "atomic"
    vmax = np.abs(v_cpu).max()
    assert vmax > 1e-3  # something moves
    assert x_gpu.shape == x_cpu.shape
    assert np.abs(x_gpu - x_cpu).max() < 1e-10 * max(1.0, np.abs(x_cpu).max())
    assert np.abs(v_gpu - v_cpu).max() < 1e-8 * vmax


def test_cpu_only_strategies_are_refused_on_the_gpu(tmp_path):
    """The private scatter (a grid copy per CPU thread) and the team mode (CPU threads
    behind spin barriers) are CPU strategies: asked for on a GPU, a clear error."""
    res = _script(tmp_path, '''
        from timpm.simulation.solver import Solver
        timpm.init(arch=GPU)
        scene = get_problem("vibrating-string").scene(elements=64)
        out = {}
        for opts in (dict(scatter="private"), dict(mode="team")):
            try:
                Solver(scene, **opts)
                out[str(opts)] = "accepted"
            except ValueError as exc:
                out[str(opts)] = str(exc)
        print(json.dumps(out))
        ''')
    assert "runs on the CPU only" in res[str(dict(scatter="private"))]
    assert "CPU threads" in res[str(dict(mode="team"))]


def test_a_gpu_is_started_from_the_main_thread_only(tmp_path):
    """Started from another thread, the GPU context is freed from the main thread at the
    interpreter's exit, and CUDA aborts the process (SIGABRT, seen on an H100): refused
    with a clear error; the main thread then starts it and runs."""
    res = _script(tmp_path, '''
        import threading
        out = {}
        def start():
            try:
                timpm.init(arch=GPU)
                out["worker"] = "started"
            except runtime.WrongThread as exc:
                out["worker"] = str(exc)
        thread = threading.Thread(target=start, name="worker")
        thread.start(); thread.join()
        timpm.init(arch=GPU)
        s = timpm.Solver(get_problem("vibrating-string").scene(elements=8))
        s.run(n_steps=10)
        out["main"] = runtime.arch()
        print(json.dumps(out))
        ''')
    assert res["worker"].startswith(f"timpm starts a GPU backend ({GPU}) from the main "
                                    f"thread only, not from 'worker'")
    assert res["main"] == GPU
