"""The benchmark harness: the throughput benchmark (:mod:`harness.bench`), the NumPy
baselines (:mod:`harness.numpy_mpm`), Taichi's mpm88 run headless (:mod:`harness.mpm88`)
and a ``timpm`` command run as a user runs it (:mod:`harness.cli_run`).

Not part of the ``timpm`` package: the scripts in ``benchmarks/`` import it as ``harness``
(Python puts a script's folder first on ``sys.path``); tests and the worker processes the
harness starts put ``BENCHMARKS`` on ``sys.path`` themselves.
"""
from pathlib import Path

#: the benchmarks folder, which holds this package
BENCHMARKS = Path(__file__).resolve().parent.parent
