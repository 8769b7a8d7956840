"""The ``timpm`` command (:mod:`.main`: every subcommand and its options) and its soil
commands (:mod:`.soil`: element tests and the factor of safety).

The top layer, beside the scene files: it may import every other part of the package
(``tests/test_layers.py``).  ``python -m timpm`` runs :func:`timpm.cli.main.entry`.
"""
