"""Output: plots (:mod:`.viz`) and the particle renderer and GIF writer (:mod:`.render`).

Layer 6: may import everything below it (studies, scenarios, the model), never the
command line (``tests/test_layers.py``).  Import the modules themselves, e.g.
``from timpm.output.viz import plot_convergence``.
"""
