"""Robust addition 2, the escape out of local minima, with guaranteed progress.

When the straight way to the target is blocked within `follow_range`, or the field pushes away from the way,
or the progress detector finds none, the robot descends a navigation function (twbr_planner.navigation: a
cost-to-go over a grid of the static obstacles, which has no minimum but the target) and leaves it once it
is `leave_progress` closer to the target than where it started and the way towards the target is free
(TangentBug's rule, Kamon, Rivlin & Rimon 1998); touching a disc its way turns into, it slides off the disc
first (docs/planner.md, addition 2). Where no way leads to the target it follows the obstacles'
boundary instead (the tangent of their normal, at `follow_clearance`, on the side nearer the target's
direction, turning to the other side after `follow_flip_time` without leaving).
"""

from __future__ import annotations

import math

from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_FOLLOW_CLEARANCE,
    A_FOLLOW_FLIP_TIME,
    A_FOLLOW_GAIN,
    A_FOLLOW_RANGE,
    A_FREE_MARGIN,
    A_LEAVE_PROGRESS,
    A_ROBOT_RADIUS,
    R_FOLLOW_SIDE,
    R_FOLLOW_SINCE,
    R_FOLLOWING,
    R_HIT_DISTANCE,
    R_STALLED,
)
from twbr_planner.navigation import navigation_direction


@kernel
def boundary_normal(x, y, positions, radii, robot_radius, reach):
    """Unit vector away from the obstacles within `reach` of the footprint (weighted by closeness), and the
    smallest clearance among them; (0, 0, inf) when none is that close."""
    nx = 0.0
    ny = 0.0
    nearest = math.inf
    for j in range(radii.shape[0]):
        ax = x - positions[j, 0]
        ay = y - positions[j, 1]
        centre = max(math.sqrt(ax * ax + ay * ay), 1e-9)
        d = centre - radii[j] - robot_radius
        if d > reach:
            continue
        w = 1.0 / (max(d, 0.02) + 0.05) ** 2
        nx += w * ax / centre
        ny += w * ay / centre
        nearest = min(nearest, d)
    norm = math.hypot(nx, ny)
    if norm < 1e-12:
        return 0.0, 0.0, nearest
    return nx / norm, ny / norm, nearest


@kernel
def escape(a, m, stamp, x, y, distance, moving_target, target_x, target_y, gx, gy, way_x, way_y, way_free,
           blocked_at, total_x, total_y, positions, radii, moving):
    """(total_x, total_y, side, escaping): the escape's direction in place of the field's while it goes on;
    side +1 / -1 the side it passes the target's direction on (0 when not escaping)."""
    if a[A_FOLLOW_RANGE] <= 0.0:
        return total_x, total_y, 0.0, False
    robot_radius = a[A_ROBOT_RADIUS]
    nx, ny, near_boundary = boundary_normal(x, y, positions, radii, robot_radius, a[A_FOLLOW_RANGE])
    escape_x = 0.0
    escape_y = 0.0
    found = False
    if m[R_FOLLOWING] != 0.0:
        # TangentBug's leave rule: closer than where following began, and a free way towards the target for
        # way_look (what lies beyond is met as it comes)
        if way_free and (distance < m[R_HIT_DISTANCE] - a[A_LEAVE_PROGRESS] or moving_target):
            m[R_FOLLOWING] = 0.0
        else:  # the A* runs only while the escape goes on
            escape_x, escape_y, found = navigation_direction(x, y, target_x, target_y, positions, radii, moving,
                                                             robot_radius + a[A_FREE_MARGIN])
            if not found and near_boundary == math.inf:
                m[R_FOLLOWING] = 0.0  # no way and lost the boundary: back to the field
            elif not found and stamp - m[R_FOLLOW_SINCE] > a[A_FOLLOW_FLIP_TIME]:
                m[R_FOLLOW_SIDE] = -m[R_FOLLOW_SIDE]
                m[R_FOLLOW_SINCE] = stamp
                m[R_HIT_DISTANCE] = distance
    elif near_boundary < math.inf and (
            (not way_free and blocked_at <= a[A_FOLLOW_RANGE] + robot_radius)  # no way, blocked close by
            or total_x * way_x + total_y * way_y < 0.0  # or the field pushes away from the way: a basin
            or m[R_STALLED] != 0.0):  # or the progress detector found none
        m[R_FOLLOWING] = 1.0
        m[R_HIT_DISTANCE] = distance
        m[R_FOLLOW_SINCE] = stamp
        # the side whose tangent is nearer the target's direction
        m[R_FOLLOW_SIDE] = 1.0 if (-ny * gx + nx * gy) >= 0.0 else -1.0
    # boundary following's push out along the normal, towards follow_clearance (used only near a boundary)
    correction = a[A_FOLLOW_GAIN] * (a[A_FOLLOW_CLEARANCE] - near_boundary)
    if m[R_FOLLOWING] != 0.0 and found:
        # down the navigation function; the side is the one it passes the target's direction on
        side = 1.0 if gx * escape_y - gy * escape_x >= 0.0 else -1.0
        inward = escape_x * nx + escape_y * ny
        if near_boundary < a[A_FREE_MARGIN] and inward < 0.0:
            # touching a disc the grid's way cuts into (its cell lies inside the inflated disc): slide off it
            # along its tangent and out, as boundary following would; straight on, the safety filter holds
            # the turn and the collision monitor the speed, and the robot stands pressed against it
            escape_x += (correction - inward) * nx
            escape_y += (correction - inward) * ny
        return escape_x, escape_y, side, True
    if m[R_FOLLOWING] != 0.0 and near_boundary < math.inf:
        side = m[R_FOLLOW_SIDE]
        return -ny * side + correction * nx, nx * side + correction * ny, side, True
    return total_x, total_y, 0.0, False
