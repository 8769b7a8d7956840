"""Output: plots (:mod:`.viz`), the particle renderer and GIF writer (:mod:`.render`), field
files (:mod:`.fields`) and the printed tables of runs (:mod:`.tables`).

Layer 6: may import everything below it (studies, scenarios, the model), never the
command line (``tests/test_layers.py``).  Import the modules themselves, e.g.
``from timpm.output.viz import plot_convergence``.
"""
