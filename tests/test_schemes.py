"""The transfer schemes as units (schemes/): each is one file with its step as a list
of labelled phases, chosen from the feature set; a scheme's own run-time values and grid
fields come with it.  Their physics is tested elsewhere (test_world, test_study: the PIC
blend damps the oedometer's at-rest noise and keeps momentum)."""
import pytest

from timpm import Body, Box, World
from timpm.engine.features import plan
from timpm.schemes import REGISTRY, Affine, MUSL, PICBlend, scheme_class
from timpm.materials import NeoHookean


def _world(transfer="musl", pic_fraction=0.0, basis="uniform-bspline2", walls="slip"):
    rubber = NeoHookean(E=1e4, nu=0.3, density=1000.0)
    return World(domain=(1.0, 1.0), cells=8, bodies=[Body(Box((0.3, 0.3), (0.6, 0.6)), rubber)],
                 transfer=transfer, basis=basis, pic_fraction=pic_fraction, walls=walls)


@pytest.mark.parametrize("transfer, pic, expected", [
    ("musl", 0.0, MUSL), ("musl", 0.2, PICBlend), ("apic", 0.0, Affine),
    ("mls-mpm", 0.0, Affine)])
def test_the_feature_set_picks_its_scheme(transfer, pic, expected):
    features, layout = plan(_world(transfer, pic), mode="serial")
    assert scheme_class(features) is expected
    # the scheme's own run-time values reach the layout from the Model's attributes
    assert set(expected.PARAMS) <= set(layout.values)
    if expected is PICBlend:
        assert layout.values["pic_fraction"] == 0.2


def test_a_variant_is_registered_before_the_scheme_it_changes():
    assert REGISTRY.index(PICBlend) < REGISTRY.index(MUSL)
    assert issubclass(PICBlend, MUSL)


@pytest.mark.parametrize("transfer, pic, walls, mode", [
    ("musl", 0.0, "slip", "serial"), ("musl", 0.3, "slip", "serial"),
    ("apic", 0.0, None, "serial"), ("mls-mpm", 0.0, "sticky", "serial"),
    ("apic", 0.0, "slip", "team"), ("musl", 0.3, None, "team")])
def test_every_step_is_a_list_of_labelled_phases(transfer, pic, walls, mode):
    from timpm.platform import runtime

    if mode == "team" and runtime.cpu_threads() < 2:
        pytest.skip("a team needs two CPU threads")
    from timpm.simulation.solver import Solver

    solver = Solver(_world(transfer, pic, walls=walls), mode=mode, energies=False)
    features, phases = solver.features, solver.program().phases
    solver.release()
    labels = [ph.label for ph in phases]
    assert len(set(labels)) == len(labels) and all(labels)
    kinds = [ph.kind for ph in phases]
    assert kinds[-1] == "particles"  # the step ends with G2P of the particle state
    assert "scatter" in kinds and "nodes" in kinds
    if features.team:  # a team runs every phase on its blocks: no phase with its own loops
        assert "whole" not in kinds


def test_a_scheme_brings_its_own_grid_fields():
    from timpm.simulation.solver import Solver

    fields = {}
    for pic in (0.0, 0.3):
        s = Solver(_world("musl", pic), energies=False, mode="serial")
        fields[pic] = set(s.program().grid_fields)
        s.release()
    assert "gv" in fields[0.3] and "gv" not in fields[0.0]  # v_i^L: the PIC blend's only


def test_a_1d_wall_reads_the_momentum_in_every_mode():
    """The rows the 1D run sums add are the ones the scheme's P2G scatters: with a wall
    the MUSL grid phase reads P_i, so the fused serial mode (run sums) must add it.  Before
    the schemes listed their rows it did not, and a block pushed against a slip wall moved
    1.8 cm differently in 200 steps than in the parallel mode; now they agree to
    round-off."""
    import numpy as np

    from timpm import Grid1D, Material, Scene
    from timpm.simulation.solver import Solver

    x = (np.arange(48) + 0.5) * 0.6 / 48
    out = {}
    for mode in ("serial", "parallel"):
        scene = Scene(grid=Grid1D(n_elements=16, h=1.0 / 16), material=Material(E=100.0, density=1.0),
                      positions=x, volume=np.full(48, 0.6 / 48), velocity=np.full(48, -0.5),
                      dt=1e-3, walls={"left": "slip"})
        s = Solver(scene, mode=mode, energies=False)
        assert s.features.run_sums == (mode == "serial")
        s.run(n_steps=200)
        out[mode] = s.positions().copy()
        s.release()
    assert out["serial"].min() > 0.0  # the wall held the block
    np.testing.assert_allclose(out["serial"], out["parallel"], rtol=0, atol=1e-12)
