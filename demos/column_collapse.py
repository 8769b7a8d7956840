"""Demo: column-collapse, written to an animated GIF with its diagnostic plot.

    python demos/column_collapse.py [--out column_collapse.gif] [--frames 60] [--param NAME=VALUE ...]

The same as `timpm demo column-collapse --out column_collapse.gif --plot column_collapse.png`;
see timpm/scenarios/demos.py for the scene, its parameters and the comparison it makes.
"""
import sys

from timpm.cli.main import demo_script

if __name__ == "__main__":
    sys.exit(demo_script("column-collapse"))
