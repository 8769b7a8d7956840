"""Demo: dam-break, written to an animated GIF with its diagnostic plot.

    python demos/dam_break.py [--out dam_break.gif] [--frames 60] [--param NAME=VALUE ...]

The same as `timpm demo dam-break --out dam_break.gif --plot dam_break.png`;
see timpm/scenarios/demos.py for the scene, its parameters and the comparison it makes.
"""
import sys

from timpm.cli.main import demo_script

if __name__ == "__main__":
    sys.exit(demo_script("dam-break"))
