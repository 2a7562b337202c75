"""Balance quantities of one robot: centre of mass, support polygon from its contacts, ZMP, is_balanced.

The ZMP is the cart-table estimate from the CoM and its acceleration (DART's, after the contact impulses):
x_zmp = x_com - h * a_x / (a_z + g). Standing still it equals the centre of pressure of the contact forces;
under a push or while tipping it leaves the support polygon, which the centre of pressure by construction
never does.

The centre of pressure is also *measured*, as a real robot measures it: from the foot force/torque sensors
(``center_of_pressure``). When the robot has them and they carry its weight, ``is_balanced`` says whether the
measured centre of pressure keeps COP_MARGIN inside the support polygon (a robot starting to tip presses on the
edge it tips over); otherwise whether the model-based ZMP is inside. ``source`` says which was used.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

# The measured centre of pressure must stay this far inside the support polygon (m) for is_balanced.
COP_MARGIN = 0.01
# Below this share of the robot's weight on the foot sensors (in the air, lifted), the measured centre of
# pressure means nothing: is_balanced falls back to the ZMP.
COP_MIN_LOAD = 0.2


@dataclass
class BalanceState:
    center_of_mass: tuple[float, float, float]
    support_polygon: list[tuple[float, float, float]]   # convex hull of contact points, counter-clockwise
    zmp: tuple[float, float]
    is_balanced: bool
    cop: tuple[float, float] | None = None    # measured by the foot force/torque sensors, when there are some
    source: str = "zmp"                       # what is_balanced judged: "cop" (measured) or "zmp" (model)


@dataclass
class FootWrench:
    """A foot sensor's reading in the world frame: the wrench the foot passes to the leg (≈ the ground's
    reaction) about the sensor point."""

    point: Sequence[float]    # sensor (joint origin) position
    force: Sequence[float]
    torque: Sequence[float]


def center_of_pressure(feet: list[FootWrench], ground_z: float) -> tuple[tuple[float, float] | None, float]:
    """(x, y) where the measured ground reaction acts on the plane ``z = ground_z``, and the vertical load.

    A force f acting at p on the ground has the moment τ = (p - s) × f about the sensor point s, d above the
    ground: p_x = s_x + (-τ_y - d f_x) / f_z, p_y = s_y + (τ_x - d f_y) / f_z; the feet combine weighted by f_z.
    """
    total = 0.0
    x = y = 0.0
    for foot in feet:
        fz = float(foot.force[2])
        if fz <= 1e-6:
            continue   # not pressing on the ground
        d = float(foot.point[2]) - ground_z
        px = foot.point[0] + (-foot.torque[1] - d * foot.force[0]) / fz
        py = foot.point[1] + (foot.torque[0] - d * foot.force[1]) / fz
        x += fz * float(px)
        y += fz * float(py)
        total += fz
    if total <= 0:
        return None, 0.0
    return (x / total, y / total), total


def convex_hull(points: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    """Andrew's monotone chain; counter-clockwise, no repeated end point, collinear points dropped."""
    unique = sorted(set(points))
    if len(unique) <= 2:
        return unique
    # the turn test (o -> a -> b clockwise or straight: cross(a - o, b - o) <= 0) written out: a function call
    # per test cost as much as the rest of the hull (it runs at 100 Hz on ~16 points)
    lower: list[tuple[float, float]] = []
    for p in unique:
        px, py = p
        while len(lower) >= 2:
            (ox, oy), (ax, ay) = lower[-2], lower[-1]
            if (ax - ox) * (py - oy) - (ay - oy) * (px - ox) > 0:
                break
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(unique):
        px, py = p
        while len(upper) >= 2:
            (ox, oy), (ax, ay) = upper[-2], upper[-1]
            if (ax - ox) * (py - oy) - (ay - oy) * (px - ox) > 0:
                break
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def inside_polygon(point: tuple[float, float], polygon: list[tuple[float, float]], tolerance: float = 1e-6) -> bool:
    """Whether ``point`` lies in a counter-clockwise convex polygon (edges included, within ``tolerance`` m)."""
    if len(polygon) < 3:
        return False
    px, py = point
    for (ax, ay), (bx, by) in zip(polygon, polygon[1:] + polygon[:1], strict=True):
        edge = math.hypot(bx - ax, by - ay)
        if edge == 0:
            continue
        # signed distance to the edge's left side; negative = outside
        if ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / edge < -tolerance:
            return False
    return True


def balance_state(com: Sequence[float], com_acceleration: Sequence[float], gravity_z: float,
                  contacts: Sequence[Sequence[float]], feet: list[FootWrench] | None = None,
                  weight: float = 0.0) -> BalanceState:
    """Compute the balance quantities from the CoM and the points where this robot touches other models (world
    frame), with the measured centre of pressure when foot sensors are given (``weight``: the robot's, N).
    Plain floats: it runs at 100 Hz on a few vectors, where numpy's per-call cost is the whole cost."""
    cx, cy, cz = (float(v) for v in com)
    hull = convex_hull((float(p[0]), float(p[1])) for p in contacts)
    ground_z = sum(float(p[2]) for p in contacts) / len(contacts) if contacts else 0.0
    polygon = [(x, y, ground_z) for x, y in hull]
    height = cz - ground_z
    denominator = float(com_acceleration[2]) - gravity_z
    if abs(denominator) > 1e-6:
        zmp_xy = (cx - height * float(com_acceleration[0]) / denominator,
                  cy - height * float(com_acceleration[1]) / denominator)
    else:
        zmp_xy = (cx, cy)    # free fall or no gravity: the estimate is undefined, use the CoM
    cop, load = center_of_pressure(feet, ground_z) if feet else (None, 0.0)
    if cop is not None and contacts and load >= COP_MIN_LOAD * weight:
        balanced, source = inside_polygon(cop, hull, tolerance=-COP_MARGIN), "cop"
    else:
        balanced, source = inside_polygon(zmp_xy, hull), "zmp"
    return BalanceState(
        center_of_mass=(cx, cy, cz),
        support_polygon=polygon,
        zmp=zmp_xy,
        is_balanced=balanced,
        cop=cop,
        source=source,
    )
