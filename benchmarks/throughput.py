"""Throughput side by side: timpm, Taichi's own mpm88 (headless) and NumPy, with the
machine's bounds.  The same as ``timpm bench``:

    python benchmarks/throughput.py [--size full|quick|tiny] [--threads 1,2] [--out docs/throughput]

Writes OUT.json, OUT.md (the tables quoted in the README) and OUT.png.  See
benchmarks/README.md for what limits each regime.
"""
from timpm.bench import main

if __name__ == "__main__":
    raise SystemExit(main())
