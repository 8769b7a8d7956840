"""Throughput side by side: timpm, Taichi's own mpm88 (headless) and NumPy, with the
machine's bounds:

    python benchmarks/throughput.py [--size full|quick|tiny] [--threads 1,2] [--out docs/throughput]

Writes OUT.json, OUT.md (the tables quoted in the README) and OUT.png.  The harness is
``benchmarks/harness/bench.py``; see benchmarks/README.md for what limits each regime.
"""
from harness.bench import main  # benchmarks/ is on sys.path: it holds this script

if __name__ == "__main__":
    raise SystemExit(main())
