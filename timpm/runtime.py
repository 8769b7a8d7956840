"""Taichi start-up: one CPU runtime per process, started on first use."""
from __future__ import annotations

import os

import taichi as ti

__all__ = ["ensure_init", "init"]

_state: dict = {}


def init(threads: int | None = None, debug: bool = False, precision: str = "f64") -> None:
    """Start Taichi on the CPU backend.

    ``threads`` caps the worker threads (default: ``TIMPM_THREADS`` or all cores);
    ``precision`` sets the default float type of literals and fields ("f64" or "f32");
    ``debug=True`` turns on Taichi's own bounds checks (slow).  Calling it again with
    other settings restarts Taichi, which invalidates every existing solver.
    """
    if precision not in ("f64", "f32"):
        raise ValueError(f"precision must be 'f64' or 'f32', got {precision!r}")
    if threads is None and os.environ.get("TIMPM_THREADS"):
        threads = int(os.environ["TIMPM_THREADS"])
    settings = dict(threads=threads, debug=debug, precision=precision)
    if _state.get("settings") == settings:
        return
    kwargs = dict(arch=ti.cpu, default_fp=ti.f64 if precision == "f64" else ti.f32,
                  debug=debug, log_level=ti.WARN)
    if threads:
        kwargs["cpu_max_num_threads"] = int(threads)
    ti.init(**kwargs)
    _state["settings"] = settings


def ensure_init() -> None:
    """Start Taichi with the defaults unless it was started already."""
    if "settings" not in _state:
        init()
