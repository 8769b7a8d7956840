"""Bishop's simplified method of slices: a slope's factor of safety on circular slip
surfaces, the reference the strength-reduction factors are set beside.  NumPy only.

The ground is a polygon (2D, y up; the soil below its upper boundary), one Mohr-Coulomb
soil (c', phi', unit weight gamma), and a water table y_w(x) (``water_table``: a number,
a still level, or a function of x; None: dry).  Below the table the pore pressure is
hydrostatic, u = gamma_w (y_w(x) - y), and where the table stands above the ground the
free water presses on it, p = gamma_w (y_w - y_s) normal to the surface.  For the slice of width b, base inclination alpha,
weight W (soil and free water) and base pore pressure u, Bishop's simplified method
(Bishop 1955) solves

    F = sum [c' b + (W + p b - u b) tan(phi')] / m_alpha  /  (sum W sin(alpha) + M_w / R),
    m_alpha = cos(alpha) + sin(alpha) tan(phi') / F

by fixed-point iteration, M_w the moment of the free water's pressure about the centre
(its vertical part enters the slice's normal force; e.g. Duncan & Wright, Soil Strength
and Slope Stability).  Under water standing above the whole slope this is the buoyant
weight's analysis (the pressure on a closed surface is Archimedes' force, and on the
circle it passes through the centre).
The factor is the smallest over a grid of circles through the ground's surface that stay
above its base (``floor``).
"""
import math

import numpy as np

__all__ = ["bishop_circle", "bishop_search", "ground_surface", "GAMMA_W"]

GAMMA_W = 1000.0 * 9.81  # the unit weight of water (rho_w = 1000 kg/m^3), N/m^3


def ground_surface(polygon):
    """The ground surface y_s(x) of a polygon (its upper boundary), vectorised."""
    P = np.asarray(polygon, dtype=np.float64)
    segments = np.stack([P, np.roll(P, -1, axis=0)], axis=1)

    def y_s(x):
        x = np.atleast_1d(np.asarray(x, dtype=np.float64))
        top = np.full(x.shape, -np.inf)
        for (x0, y0), (x1, y1) in segments:
            if x1 == x0:
                continue
            lo, hi = min(x0, x1), max(x0, x1)
            inside = (x >= lo) & (x <= hi)
            y = y0 + (y1 - y0) * (x[inside] - x0) / (x1 - x0)
            top[inside] = np.maximum(top[inside], y)
        return top

    return y_s


def _table(water_table):
    if water_table is None:
        return lambda x: np.full(np.shape(x), -np.inf)
    if callable(water_table):
        return water_table
    level = float(water_table)
    return lambda x: np.full(np.shape(x), level)


def bishop_circle(polygon, centre, radius, cohesion, friction_angle, unit_weight,
                  water_table=None, slices=200, gamma_w=GAMMA_W):
    """Bishop's factor on one circle (None where it cuts no soil, crosses the polygon's
    ends, or its slices turn unphysical, m_alpha <= 0.2: a circle too steep at its exit)."""
    y_s, y_w = ground_surface(polygon), _table(water_table)
    xc, yc = centre
    P = np.asarray(polygon, dtype=np.float64)
    x0, x1 = max(P[:, 0].min(), xc - radius), min(P[:, 0].max(), xc + radius)
    if x1 <= x0:
        return None
    def circle(x):
        return yc - np.sqrt(np.maximum(radius ** 2 - (x - xc) ** 2, 0.0))

    def depth(x):
        return y_s(x) - circle(x)

    edges = np.linspace(x0, x1, slices + 1)
    x = 0.5 * (edges[:-1] + edges[1:])
    cut = depth(x) > 0.0
    inside = np.flatnonzero(cut)
    # one sliding mass, entering and leaving through the surface (not the polygon's ends)
    if len(inside) < 3 or cut[0] or cut[-1] or inside[-1] - inside[0] + 1 != len(inside):
        return None
    # its ends where the circle meets the surface (bisection), the slices between them
    ends = []
    for out, into in ((x[inside[0] - 1], x[inside[0]]), (x[inside[-1] + 1], x[inside[-1]])):
        for _ in range(50):
            mid = 0.5 * (out + into)
            if depth(mid)[0] > 0.0:
                into = mid
            else:
                out = mid
        ends.append(0.5 * (out + into))
    edges = np.linspace(ends[0], ends[1], slices + 1)
    x = 0.5 * (edges[:-1] + edges[1:])
    b = np.diff(edges)
    base, top = circle(x), y_s(x)
    soil = np.maximum(top - base, 0.0)
    cut = soil > 0.0
    table = y_w(x)
    # the free water's pressure on the ground, p = gamma_w (y_w - y_s): on each slice's
    # top its vertical part p b (the slice's normal force takes it) and the moment of
    # both parts, p (y_s', -1) per unit x, about the centre
    p = gamma_w * np.maximum(table - top, 0.0) * cut
    slope = np.gradient(top, x)
    m_water = np.sum(b * ((x - xc) * -p - (top - yc) * p * slope))  # counter-clockwise
    W = b * (unit_weight * soil + p)
    u = gamma_w * np.maximum(table - base, 0.0)
    # the mass slides toward the lower side: where the ground falls to +x, the slices
    # left of the centre drive it (alpha > 0 there)
    span = P[:, 0].max() - P[:, 0].min()
    ends = y_s(np.array([P[:, 0].min() + 1e-6 * span, P[:, 0].max() - 1e-6 * span]))
    facing = 1.0 if ends[1] < ends[0] else -1.0
    sin_a = facing * (xc - x) / radius
    cos_a = np.sqrt(np.maximum(1.0 - sin_a ** 2, 0.0))
    tan_phi = math.tan(math.radians(friction_angle))
    # the driving moment / R: the soil's weight and the free water's pressure, in the
    # sense of the slide (counter-clockwise where the ground falls to +x)
    drive = np.sum((b * unit_weight * soil * sin_a)[cut]) + facing * m_water / radius
    if drive <= 0.0:
        return None
    F = 1.0
    for _ in range(200):
        m = cos_a + sin_a * tan_phi / F
        if np.any(m[cut] <= 0.2):
            return None
        resist = np.sum(((cohesion * b + np.maximum(W - u * b, 0.0) * tan_phi) / m)[cut])
        F_new = resist / drive
        if abs(F_new - F) < 1e-10 * F:
            return F_new
        F = F_new
    return F


def bishop_search(polygon, cohesion, friction_angle, unit_weight, water_table=None,
                  floor=None, centres=None, slices=200):
    """The smallest Bishop factor over circles: centres on a grid above the slope
    (``centres``: two arrays of x and y; default the box over the polygon's span, up to
    twice its height above it), each circle's radius from its centre down to the floor
    (default the polygon's bottom) and to the toe corners; returns (F, centre, radius)."""
    P = np.asarray(polygon, dtype=np.float64)
    floor = P[:, 1].min() if floor is None else floor
    H = P[:, 1].max() - floor
    if centres is None:
        centres = (np.linspace(P[:, 0].min(), P[:, 0].max(), 41),
                   np.linspace(P[:, 1].max(), P[:, 1].max() + 2.0 * H, 41))
    best = (math.inf, None, None)
    for xc in centres[0]:
        for yc in centres[1]:
            deepest = yc - floor  # the circle touching the floor
            for radius in np.linspace(0.2 * H, deepest, 25):
                F = bishop_circle(P, (xc, yc), radius, cohesion, friction_angle, unit_weight,
                                  water_table, slices)
                if F is not None and F < best[0]:
                    best = (F, (float(xc), float(yc)), float(radius))
    return best
