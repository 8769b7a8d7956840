"""timpm: high-order material point method in Taichi."""
from .basis import BASES, Basis, Linear, get_basis
from .runtime import init
from .scene import (Constant, Grid1D, Material, Ramp, Scene, Sine, Traction,
                    critical_time_step, equidistant_particles)
from .solver import SimulationError, Solver

__version__ = "0.1.0"

__all__ = [
    "BASES", "Basis", "Linear", "get_basis", "init", "Constant", "Grid1D", "Material",
    "Ramp", "Scene", "Sine", "Traction", "critical_time_step", "equidistant_particles",
    "SimulationError", "Solver", "__version__",
]
