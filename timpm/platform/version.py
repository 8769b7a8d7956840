"""timpm's version (pyproject.toml gives the same: tests/test_layers.py compares them)."""
__version__ = "0.1.0"
