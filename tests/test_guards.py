"""Large-deformation guards: a particle whose volume ratio V/V0 leaves the allowed range
stops the run with its step and index named (issue 15)."""
import numpy as np
import pytest

import timpm
from timpm import Body, Box, LinearElastic, SimulationError, Solver, World
from timpm.platform.errors import ErrorCode
from timpm.problems import get_problem


def _crush(transfer="apic"):
    # an elastic block (E 1e4 Pa) driven at 20 m/s into a slip wall: far beyond what 32
    # cells resolve, without the guard it is crushed to V/V0 ~ 1e-152 and runs on
    return World(domain=(1.0, 0.5), cells=32, basis="uniform-bspline2", transfer=transfer,
                 courant=0.9, bodies=Body(Box((0.35, 0.15), (0.65, 0.35)),
                                          LinearElastic(1e4, 0.3, 1e3), velocity=(-20.0, 0.0)))


@pytest.mark.parametrize("transfer", ["apic", "mls-mpm"])
def test_a_crushed_body_stops_the_run_naming_step_and_particle(transfer):
    world = _crush(transfer)
    with pytest.raises(SimulationError) as err:
        Solver(world).run(t_end=0.3)
    e = err.value
    assert e.code == ErrorCode.VOLUME_RANGE and e.step > 0 and 0 <= e.particle < world.n_particles
    assert f"step {e.step} " in str(e) and f"particle {e.particle} " in str(e)
    assert "outside [0.01, 100]" in str(e) and "volume_range=None" in str(e)
    # the guard is what stopped it: unguarded, the same run crushes the body to nothing
    unguarded = Solver(world, volume_range=None).run(t_end=0.3)
    assert (unguarded.volumes() / world.volume).min() < 1e-3


@pytest.mark.parametrize("value", [(0.0, 10.0), (0.5, 0.9), (2.0, 10.0), "wide", (0.1,)])
def test_a_bad_volume_range_is_refused(value):
    with pytest.raises(ValueError, match="volume_range must"):
        Solver(_crush(), volume_range=value)


def test_free_expansion_is_a_compile_time_choice_of_the_material():
    water = timpm.WeaklyCompressibleFluid(2e5, 1e3)
    assert water.free_expansion and not timpm.WeaklyCompressibleFluid(2e5, 1e3, tension=True) \
        .free_expansion
    assert not LinearElastic(1e4, 0.3, 1e3).free_expansion
    assert timpm.DruckerPrager(3.5e5, 0.3, 1500.0, 30.0).free_expansion


def test_a_body_force_run_checked_every_few_steps_reports_the_first_failure_as_before():
    # with a body force the fused mode launches a step at a time (b(X, t) uploaded before
    # each) and reads the failure back every check_every steps: a particle thrown off the
    # grid mid-interval is named with the same step, and the run stops in the same state,
    # as when every step is checked
    scene = get_problem("mms-1d").scene(elements=16)
    reports = []
    for check_every in (1, 16):
        s = Solver(scene, mode="serial", check_every=check_every)
        assert s.features.body_force
        s.run(n_steps=3)
        v = s.read("v").copy()
        v[5] = 40.0 * scene.model.h / scene.model.dt  # 40 cells a step: off the grid
        s.write("v", v)
        with pytest.raises(SimulationError) as err:
            s.run(n_steps=30)
        e = err.value
        reports.append((e.code, e.step, e.particle, s.step, s.positions().copy()))
        s.release()
    (code, step, particle, at, x), (code16, step16, particle16, at16, x16) = reports
    assert code == code16 == ErrorCode.OFF_GRID and particle == particle16 == 5
    assert step == step16 and 3 < step < 3 + 16  # inside the first unchecked interval
    assert at == at16
    np.testing.assert_array_equal(x, x16)
