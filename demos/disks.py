"""Demo: disks, written to an animated GIF with its diagnostic plot.

    python demos/disks.py [--out disks.gif] [--frames 60] [--param NAME=VALUE ...]

The same as `timpm demo disks --out disks.gif --plot disks.png`; see timpm/demos.py for the
scene, its parameters and the comparison it makes.
"""
import sys

from timpm.cli import main

if __name__ == "__main__":
    args = sys.argv[1:]
    if "--out" not in args:
        args += ["--out", "disks.gif"]
    if "--plot" not in args:
        args += ["--plot", "disks.png"]
    sys.exit(main(["demo", "disks", *args]))
