"""Studies over many runs: drivers and convergence (:mod:`.study`), speed against error
(:mod:`.speed_error`), the updated-Lagrangian FEM comparison (:mod:`.ulfem`), the MLS
projection study (:mod:`.mls`) and their error measures (:mod:`.analysis`).

Layer 5: imports the problems, scenarios, solver and model below it, never the output
or the command line (``tests/test_layers.py``).  Import the modules themselves, e.g.
``from timpm.studies.study import convergence``.
"""
