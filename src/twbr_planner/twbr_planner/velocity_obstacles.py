"""Velocity obstacles (`method: vo`), a baseline peer of the robust method.

Fiorini & Shiller (1998), "Motion planning in dynamic environments using velocity obstacles", IJRR 17(7).
An obstacle j at p_j moving at v_j, grown by the robot's footprint and `safety_margin` to a disc of radius
R_j, forbids every robot velocity u whose relative velocity u - v_j meets the disc within `vo_horizon`
seconds (the truncated collision cone). Each planning step samples velocities (HEADINGS directions round
the circle at SPEEDS speeds up to v_max, and standing still), drops those inside any velocity obstacle,
and takes the one nearest the preferred velocity: v_max towards the target (approach_gain times the
distance near a static one), their selection strategy "towards the goal". When every sample is inside
one, the one whose first contact comes last is taken. The velocity found becomes a unicycle's command as
the paper's field's heading does (eq. 27: omega = K_s times the heading error; v scaled by its cosine).
The same limits, arrival and stuck report as the other methods; compiled, shared with the batch engine.
"""

from __future__ import annotations

import math

from twbr_common.geometry import wrap_angle
from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_K_S,
    A_MAX_YAW_RATE,
    A_ROBOT_RADIUS,
    A_SAFETY_MARGIN,
    A_V_MAX,
    A_VO_HORIZON,
    sampling_finish,
    sampling_start,
    top_speed,
)

HEADINGS = 36  # directions sampled round the circle
SPEEDS = 6  # speeds sampled, from v_max / SPEEDS to v_max


@kernel
def time_to_contact(px, py, ux, uy, radius):
    """[s] when a point at relative position (px, py) moving at relative velocity (ux, uy) first comes
    within `radius` of the origin: 0 if it is already and not leaving, inf never."""
    c = px * px + py * py - radius * radius
    b = px * ux + py * uy
    if c <= 0.0:
        return math.inf if b >= 0.0 else 0.0  # touching: only a velocity that leaves is free
    uu = ux * ux + uy * uy
    if b >= 0.0 or uu < 1e-12:
        return math.inf  # moving apart, or not moving
    disc = b * b - uu * c
    if disc < 0.0:
        return math.inf  # passes wide
    return (-b - math.sqrt(disc)) / uu


@kernel
def first_contact(x, y, ux, uy, positions, velocities, radii, grow):
    """[s] the first contact, among the obstacles grown by `grow`, of the robot at (x, y) moving at (ux, uy)."""
    first = math.inf
    for j in range(radii.shape[0]):
        t = time_to_contact(x - positions[j, 0], y - positions[j, 1], ux - velocities[j, 0], uy - velocities[j, 1],
                            radii[j] + grow)
        first = min(first, t)
    return first


@kernel
def vo_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
            velocities, radii, distances):
    """One planning step of the velocity obstacle method into `out` (Q_*)."""
    f_att_x, f_att_y, nearest, nearest_d, distance, moving_target = sampling_start(
        a, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions, radii, distances)
    preferred = top_speed(a, distance, moving_target)
    to_target = math.atan2(target_y - y, target_x - x)
    pref_x = preferred * math.cos(to_target)
    pref_y = preferred * math.sin(to_target)
    grow = a[A_ROBOT_RADIUS] + a[A_SAFETY_MARGIN]
    horizon = a[A_VO_HORIZON]
    best_cost = math.inf
    best_contact = -1.0
    best_x = 0.0
    best_y = 0.0
    for i in range(SPEEDS + 1):
        s = a[A_V_MAX] * i / SPEEDS
        for k in range(HEADINGS if i > 0 else 1):
            heading = to_target + 2.0 * math.pi * k / HEADINGS
            ux = s * math.cos(heading)
            uy = s * math.sin(heading)
            contact = min(first_contact(x, y, ux, uy, positions, velocities, radii, grow), horizon)
            cost = math.hypot(ux - pref_x, uy - pref_y)
            # outside every velocity obstacle first (contact beyond the horizon), then the latest contact,
            # then the nearest the preferred velocity
            if contact > best_contact or (contact == best_contact and cost < best_cost):
                best_contact = contact
                best_cost = cost
                best_x = ux
                best_y = uy
    chosen = math.hypot(best_x, best_y)
    alpha = math.atan2(best_y, best_x) if chosen > 0.0 else yaw
    error = wrap_angle(alpha - yaw)
    omega = min(max(a[A_K_S] * error, -a[A_MAX_YAW_RATE]), a[A_MAX_YAW_RATE])
    v = chosen * max(0.0, math.cos(error))
    sampling_finish(a, m, ring, out, stamp, x, y, distance, moving_target, nearest, nearest_d, f_att_x, f_att_y,
                    alpha, error, v, omega)
