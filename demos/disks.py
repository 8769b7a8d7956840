"""Demo: disks, written to an animated GIF with its diagnostic plot.

    python demos/disks.py [--out disks.gif] [--frames 60] [--param NAME=VALUE ...]

The same as `timpm demo disks --out disks.gif --plot disks.png`;
see timpm/scenarios/demos.py for the scene, its parameters and the comparison it makes.
"""
import sys

from timpm.cli.main import demo_script

if __name__ == "__main__":
    sys.exit(demo_script("disks"))
