"""Balance quantities of one robot: centre of mass, support polygon from its contacts, ZMP, is_balanced.

The ZMP is the cart-table estimate from the CoM and its acceleration (DART's, after the contact impulses):
x_zmp = x_com - h * a_x / (a_z + g). Standing still it equals the centre of pressure of the contact forces;
under a push or while tipping it leaves the support polygon, which the centre of pressure by construction
never does - so ``is_balanced`` (ZMP inside the polygon) carries information.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np


@dataclass
class BalanceState:
    center_of_mass: tuple[float, float, float]
    support_polygon: list[tuple[float, float, float]]   # convex hull of contact points, counter-clockwise
    zmp: tuple[float, float]
    is_balanced: bool


def convex_hull(points: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    """Andrew's monotone chain; counter-clockwise, no repeated end point, collinear points dropped."""
    unique = sorted(set(points))
    if len(unique) <= 2:
        return unique

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in unique:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(unique):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def inside_polygon(point: tuple[float, float], polygon: list[tuple[float, float]], tolerance: float = 1e-6) -> bool:
    """Whether ``point`` lies in a counter-clockwise convex polygon (edges included, within ``tolerance`` m)."""
    if len(polygon) < 3:
        return False
    px, py = point
    for (ax, ay), (bx, by) in zip(polygon, polygon[1:] + polygon[:1], strict=True):
        edge = np.hypot(bx - ax, by - ay)
        if edge == 0:
            continue
        # signed distance to the edge's left side; negative = outside
        if ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / edge < -tolerance:
            return False
    return True


def robot_contacts(contacts, skeleton_name: str) -> list[tuple[np.ndarray, float]]:
    """(point, vertical force magnitude) of every contact between the robot and anything else."""
    result = []
    for contact in contacts:
        first = contact.collisionObject1.getShapeFrame().getSkeleton().getName()
        second = contact.collisionObject2.getShapeFrame().getSkeleton().getName()
        if (first == skeleton_name) == (second == skeleton_name):
            continue  # not this robot's, or a self-contact
        force = np.asarray(contact.force)
        result.append((np.asarray(contact.point, dtype=float), float(abs(force[2]))))
    return result


def balance_state(com: np.ndarray, com_acceleration: np.ndarray, gravity_z: float,
                  contacts: list[tuple[np.ndarray, float]]) -> BalanceState:
    """Compute the balance quantities from the CoM and this robot's contacts (world frame)."""
    com = np.asarray(com, dtype=float)
    hull = convex_hull((float(p[0]), float(p[1])) for p, _ in contacts)
    ground_z = float(np.mean([p[2] for p, _ in contacts])) if contacts else 0.0
    polygon = [(x, y, ground_z) for x, y in hull]
    height = com[2] - ground_z
    denominator = float(com_acceleration[2]) - gravity_z
    if abs(denominator) > 1e-6:
        zmp = com[:2] - height * np.asarray(com_acceleration[:2]) / denominator
    else:
        zmp = com[:2].copy()    # free fall or no gravity: the estimate is undefined, use the CoM
    zmp_xy = (float(zmp[0]), float(zmp[1]))
    return BalanceState(
        center_of_mass=(float(com[0]), float(com[1]), float(com[2])),
        support_polygon=polygon,
        zmp=zmp_xy,
        is_balanced=inside_polygon(zmp_xy, hull),
    )
