"""The platform under everything else: which Taichi runs and how it starts and stops
(:mod:`.taichi_backend`, :mod:`.taichi_frontend`, :mod:`.runtime`), the named error codes
(:mod:`.errors`), the shared checks of user values (:mod:`.checks`), argument types
(:mod:`.argtypes`), the progress line (:mod:`.progress`), signals deferred to a step
boundary (:mod:`.interrupt`) and files written whole (:mod:`.files`).

The lowest layer: it imports nothing else of timpm (``tests/test_layers.py``).  Import the
modules themselves (``from timpm.platform import runtime``); this package runs no Taichi
code when imported, so that :mod:`.taichi_backend` picks the Taichi before anything loads it.
"""
