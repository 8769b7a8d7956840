"""timpm: high-order material point method in Taichi."""
import os

# Taichi's CPU workers spin for a while after each kernel; a multi-threaded BLAS started
# right after them (the critical-step eigenproblems) then crawls.  The matrices timpm
# hands to NumPy are small: one BLAS thread is the right choice (set before NumPy loads).
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
# the Taichi that runs timpm (taichi, or taichi-forge where only that is installed), then
# runtime: it imports Taichi without its banner (printed when Taichi starts)
try:
    from .platform import taichi_backend  # before anything imports taichi
except ImportError as _exc:
    import sys as _sys

    # the timpm command (its script, or python -m timpm while it is being found): one line
    # and exit 2, as every other argument error; a Python import raises as usual
    if (os.path.basename(_sys.argv[0]) == "timpm" or _sys.argv[:1] == ["-m"]) \
            and type(_exc).__name__ == "TaichiChoiceError":
        _sys.stderr.write(f"timpm: error: {_exc}\n")
        raise SystemExit(2) from None
    raise
from .platform.runtime import init
from .bases import BASES, Basis, Linear, get_basis
from .model.scene import (Constant, Grid1D, Material, Ramp, Scene, Sine, Traction,
                          critical_time_step, equidistant_particles)
from .materials import (DruckerPrager, LinearElastic, MohrCoulomb, MohrCoulombSoftening,
                        NeoHookean, PoreWater, WeaklyCompressibleFluid, get_material)
from .simulation.solver import SimulationError, Solver
from .simulation.batch import Batch
from .model.world import Ball, Body, Box, Plane, Points, Polygon, Prism, Wall, World
from .model.geostatic import K0, GravityLoading
from .simulation.loading import gravity_loading
from .model.model import Model
from .model.water import Water
from .model.random_field import RandomField

from .platform.version import __version__

__all__ = [
    "taichi_backend", "BASES", "Basis", "Linear", "get_basis", "init", "Constant", "Grid1D",
    "Material", "Ramp", "Scene", "Sine", "Traction", "critical_time_step",
    "equidistant_particles",
    "SimulationError", "Solver", "Batch", "__version__", "World", "Body", "Box", "Ball", "Wall",
    "Plane", "Points", "Polygon", "Prism", "K0", "GravityLoading", "gravity_loading", "Model", "LinearElastic", "NeoHookean", "DruckerPrager", "MohrCoulomb",
    "MohrCoulombSoftening", "WeaklyCompressibleFluid", "get_material", "PoreWater", "Water",
    "RandomField",
]
