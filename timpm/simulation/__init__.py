"""What users call to run a model: the solver (:mod:`.solver`: a model, its compiled
program, its state and the run loop), small runs side by side (:mod:`.batch`), checkpoint
files (:mod:`.checkpoint`) and gravity loading, a damped run to rest whose stresses start a
scene (:mod:`.loading`).

Above the engine and the model, below the problems, scenarios and studies
(``tests/test_layers.py``).  Import the modules themselves
(``from timpm.simulation.solver import Solver``) or the names ``timpm`` exports.
"""
