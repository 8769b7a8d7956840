"""The study's benchmark problems, each a scene builder with its exact solution."""
from .base import Problem
from .hydrostatic_column import HydrostaticColumn
from .k0_layer import K0Layer
from .mms import MMS1D, MMS2D, MMS3D, ManufacturedSolution
from .oedometer import Oedometer
from .soil_column import LargeColumn, SoilColumn, SoilColumn2D
from .terzaghi import Terzaghi
from .vibrating_bar import VibratingBar
from .vibrating_string import VibratingString

PROBLEMS = {cls.name: cls for cls in (VibratingString, SoilColumn, VibratingBar, Oedometer,
                                      LargeColumn, SoilColumn2D, MMS1D, MMS2D, MMS3D, K0Layer,
                                      HydrostaticColumn, Terzaghi)}

__all__ = ["Problem", "VibratingString", "SoilColumn", "LargeColumn", "VibratingBar",
           "SoilColumn2D", "K0Layer", "Oedometer", "ManufacturedSolution", "MMS1D", "MMS2D", "MMS3D",
           "Terzaghi", "HydrostaticColumn", "PROBLEMS",
           "get_problem"]


def get_problem(name, **params) -> Problem:
    """A problem by name, with physical parameters overridden by ``params``."""
    if isinstance(name, Problem):
        return name.with_params(**params) if params else name
    try:
        cls = PROBLEMS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown problem {name!r}: choose one of {', '.join(PROBLEMS)}") from None
    return cls().with_params(**params) if params else cls()
