"""Scenes built from the model: the 2D demos (:mod:`.demos`) and mpm88's physics as a
World (:mod:`.mpm88`).

Layer 4: imports the solver and the model below it, never the studies, output or the
command line (``tests/test_layers.py``).
"""
from .demos import (DEMOS, MARTIN_MOYCE_N2_2, QUANTITIES, ColumnCollapse, DamBreak, DemoResult,
                    Disks, get_demo, lajeunesse_runout, lube_runout, run_demo)
from .mpm88 import MPM88, mpm88_world

__all__ = ["DEMOS", "get_demo", "run_demo", "DemoResult", "ColumnCollapse", "Disks", "DamBreak",
           "QUANTITIES", "lube_runout", "lajeunesse_runout", "MARTIN_MOYCE_N2_2",
           "MPM88", "mpm88_world"]
