"""Demo: dam-break, written to an animated GIF with its diagnostic plot.

    python demos/dam_break.py [--out dam_break.gif] [--frames 60] [--param NAME=VALUE ...]

The same as `timpm demo dam-break --out dam_break.gif --plot dam_break.png`; see timpm/demos.py for the
scene, its parameters and the comparison it makes.
"""
import sys

from timpm.cli import main

if __name__ == "__main__":
    args = sys.argv[1:]
    if "--out" not in args:
        args += ["--out", "dam_break.gif"]
    if "--plot" not in args:
        args += ["--plot", "dam_break.png"]
    sys.exit(main(["demo", "dam-break", *args]))
