"""Bishop's simplified method (timpm.studies.limit_equilibrium), the reference beside the
strength-reduction factors: Griffiths & Lane's slope against Bishop & Morgenstern's
chart, and the free water's pressure against the buoyant weight it must equal."""
import math

import numpy as np
import pytest

from timpm.studies.limit_equilibrium import ground_surface, bishop_circle, bishop_search

SLOPE = [[0.0, 0.0], [40.0, 0.0], [20.0, 10.0], [0.0, 10.0]]  # H = 10 m, 2:1, toe at x = 40
CENTRES = (np.linspace(30.0, 40.0, 11), np.linspace(18.0, 28.0, 11))  # about the toe circles


def test_bishop_gives_the_chart_factor_of_griffiths_and_lane_s_slope():
    """c' / (gamma H) = 0.05, phi' = 20 degrees, 2:1, no foundation: Bishop & Morgenstern's
    chart reads 1.38."""
    F, centre, radius = bishop_search(SLOPE, 10e3, 20.0, 20e3, centres=CENTRES)
    assert F == pytest.approx(1.38, abs=0.01)
    assert radius == pytest.approx(centre[1], abs=1.0)  # a circle down to the firm base


def test_free_water_above_the_slope_is_the_buoyant_weight():
    """Under water standing above the crest the pressure on the ground makes the analysis
    the buoyant weight's (gamma' = gamma - gamma_w, no pore pressure), on every circle."""
    for centre, radius in (((35.0, 22.5), 22.5), ((30.0, 18.0), 16.0), ((38.0, 25.0), 24.0)):
        wet = bishop_circle(SLOPE, centre, radius, 10e3, 20.0, 20e3, water_table=12.0)
        buoyant = bishop_circle(SLOPE, centre, radius, 10e3, 20.0, 20e3 - 9810.0)
        assert wet == pytest.approx(buoyant, rel=2e-4)


def test_a_long_shallow_circle_approaches_the_infinite_slope():
    """A cohesionless slope: any circle's factor stays above tan(phi) / tan(beta), and
    the search, whose flattest circles approach the surface, comes within 1 % of it."""
    beta = math.atan(0.5)
    F, _, _ = bishop_search(SLOPE, 0.0, 30.0, 20e3, centres=(
        np.linspace(0.0, 60.0, 31), np.linspace(20.0, 200.0, 31)))
    exact = math.tan(math.radians(30.0)) / math.tan(beta)
    assert exact * 0.999 < F < exact * 1.01


def test_rapid_drawdown_lowers_the_factor_below_the_dry_one():
    """The water table left at the ground surface (rapid drawdown, no free water): the
    pore pressures cut the friction, far below the dry factor and the submerged one."""
    y_s = ground_surface(SLOPE)
    dry, _, _ = bishop_search(SLOPE, 10e3, 20.0, 20e3, centres=CENTRES)
    wet, _, _ = bishop_search(SLOPE, 10e3, 20.0, 20e3, water_table=12.0, centres=CENTRES)
    drawn, _, _ = bishop_search(SLOPE, 10e3, 20.0, 20e3, water_table=y_s, centres=CENTRES)
    assert drawn < 0.7 * dry < wet
