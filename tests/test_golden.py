"""The engine keeps its results: golden outputs recorded before the redesign (the engine of
one compiled Solver per scene) against the engine now, bit for bit, on one thread.

Both engines were compiled without Taichi's fast math (``tests/golden/golden.py``): with
it, the compiler folds compile-time constants (h, dt, gravity, material constants) into
reassociated products, and values that are now read at run time round differently in the
last bits.  Without it every operation rounds as written, so equal arrays mean the same
arithmetic.  A subset runs here; ``-m slow`` runs all 37 cases in f64 and the 2D ones in
f32.

Intended changes of an output since, each replacing only the arrays it names
(``golden.py update --only ... --keys ...`` refuses if any other array differs):
2026-11-24, the strain energy of a hyperelastic material (Neo-Hookean, linear elastic) is
its stored energy W(F) V0, no longer the path integral of sigma : d_eps V (issue 15):
``energy_strain`` and ``energy_total`` of 8 cases in f64, 3 in f32.
"""
import os
import subprocess
import sys
from pathlib import Path

import pytest

GOLDEN = Path(__file__).parent / "golden" / "golden.py"

#: one case per engine path: MUSL with run sums, the banded LU, the MLS projection, a
#: traction, plasticity with friction walls and the private scatter, two materials with a
#: fluid, mpm88's J-fluid
SUBSET = ["string-linear-serial", "string-bspline3-consistent-gauss", "string-mls-serial",
          "bar-bspline2-serial", "sand-mlsmpm-private", "two-materials-serial", "mpm88-serial"]


def _check(*args):
    # the goldens are one CPU thread, whatever backend the test session runs on
    env = {k: v for k, v in os.environ.items() if k != "TIMPM_ARCH"}
    env["TIMPM_THREADS"] = "1"
    proc = subprocess.run([sys.executable, str(GOLDEN), "check", *args], capture_output=True,
                          text=True, timeout=1800, env=env)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith(("DIFF", "  "))]
    assert proc.returncode == 0, "\n".join(lines[:40]) + proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1].endswith(": 0 differ")
    return proc.stdout


def test_golden_subset_bit_for_bit():
    out = _check("--only", *SUBSET)
    assert f"{len(SUBSET)} cases" in out


@pytest.mark.slow
@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_golden_all_bit_for_bit(precision):
    _check("--precision", precision)
