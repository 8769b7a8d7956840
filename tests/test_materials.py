"""Material updates checked directly on deformation gradients, outside a scene."""
import numpy as np
import taichi as ti

from timpm.engine.params import ParamBlock
from timpm.materials import DruckerPrager
from timpm.runtime import ensure_init


@ti.data_oriented
class _Particles:
    """The particle state a material update reads and writes (what the solver holds)."""

    def __init__(self, F, density):
        n = len(F)
        self.dim = 2
        self.F = ti.Matrix.field(2, 2, float, n)
        self.plastic = ti.field(float, n)
        self.m = ti.field(float, n)
        self.vol = ti.field(float, n)
        self.sigma = ti.Matrix.field(2, 2, float, n)
        self.F.from_numpy(F)
        self.m.fill(density)  # unit initial volume
        self.vol.from_numpy(np.abs(np.linalg.det(F)))

    @ti.func
    def accumulate(self, ref: ti.template(), value):
        ref += value


def _unit(material):
    """The material's compiled unit, its constants uploaded (as a program holds them)."""
    fb = ti.FieldsBuilder()
    block = ParamBlock({"m": {name: "real" for name in type(material).CONSTANTS}}, float, fb)
    fb.finalize()
    block.set("m", material.constants(dt=1.0))
    block.upload()
    return type(material).unit(material.flags(), block.groups["m"])


def _apply(material, F, spectral):
    ensure_init()
    s = _Particles(F, material.density)
    sand = _unit(material)
    n = len(F)

    @ti.kernel
    def update():
        for p in range(n):
            Fp = s.F[p]
            if ti.static(spectral):
                s.sigma[p] = sand._update_2d(s, p, Fp)
            else:
                s.sigma[p] = sand._update_svd(s, p, Fp)

    update()
    return s.sigma.to_numpy(), s.F.to_numpy(), s.plastic.to_numpy()


def test_drucker_prager_2d_spectral_update_equals_the_svd_one():
    """The SVD-free 2D return mapping gives the stress, elastic F and plastic strain of the
    SVD form to round-off, over elastic, plastic (cone) and tension (tip) states."""
    sand = DruckerPrager(E=4e5, nu=0.3, density=1500.0, friction_angle=30.0)
    rng = np.random.default_rng(7)
    n = 3000
    rot = rng.uniform(0, 2 * np.pi, n)
    R = np.stack([np.stack([np.cos(rot), -np.sin(rot)], -1),
                  np.stack([np.sin(rot), np.cos(rot)], -1)], -2)
    stretch = np.exp(rng.normal(0.0, 0.03, (n, 2)) - 0.01)  # compression, shear and tension
    F = R @ (stretch[:, :, None] * np.swapaxes(R, 1, 2))
    F = F @ (np.eye(2) + 0.02 * rng.standard_normal((n, 2, 2)))
    F[0] = np.eye(2)                 # no strain at all
    F[1] = np.diag([0.99, 0.99])     # isotropic compression: b = m I
    sig_a, F_a, pl_a = _apply(sand, F, spectral=True)
    sig_b, F_b, pl_b = _apply(sand, F, spectral=False)
    plastic = pl_b > 0
    assert 0.2 * n < plastic.sum() < 0.9 * n  # the sample covers both branches
    scale = sand.E * 0.03
    assert np.max(np.abs(sig_a - sig_b)) < 1e-12 * scale
    assert np.max(np.abs(F_a - F_b)) < 1e-11
    assert np.max(np.abs(pl_a - pl_b)) < 1e-11
    # the returned stresses lie on or inside the cone: no tension in the mean stress
    assert np.all(np.trace(sig_a, axis1=1, axis2=2) <= 1e-9 * scale)
