"""Robust addition 1, the field: the paper's attraction and repulsion with a goal-reachable repulsion and a
way round.

The repulsion (eq. 23) acts only within `repulsion_range` of a surface (a gap the robot fits through is
not closed by its edges' fields) and is scaled by min(1, (rho_g / goal_fade)^2), rho_g the distance to the
target, so it vanishes at the target and a target next to an obstacle is reachable (Ge & Cui 2000). When
the straight way to the target is blocked within `way_look`, the direction of a fan beside it (the side
taken last first) that is free that far carries the attraction instead, so a gap beside the straight line
is taken. While the way is free the repulsion only steers: its component against the way is dropped and
it is at most `free_steer` of the attraction.
"""

from __future__ import annotations

import math

from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_FREE_MARGIN,
    A_FREE_STEER,
    A_GOAL_FADE,
    A_K_O,
    A_K_P,
    A_K_V,
    A_MIN_DISTANCE,
    A_REPULSION_RANGE,
    A_ROBOT_RADIUS,
    A_WAY_FAN_STEP,
    A_WAY_FAN_STEPS,
    A_WAY_LOOK,
    R_WAY_SIDE,
    attraction,
    repulsion,
)


@kernel
def ray_clearance(x, y, ux, uy, positions, radii, inflate, reach, moving, skip_moving):
    """Distance along the unit direction (ux, uy) from (x, y) to the first obstacle inflated by `inflate`,
    within `reach` (reach when none); obstacles flagged in `moving` are left out when skip_moving."""
    first = reach
    for j in range(radii.shape[0]):
        if skip_moving and moving[j]:
            continue
        ox = positions[j, 0] - x
        oy = positions[j, 1] - y
        along = ox * ux + oy * uy
        r = radii[j] + inflate
        across2 = ox * ox + oy * oy - along * along
        if across2 >= r * r:
            continue
        inside = math.sqrt(r * r - across2)
        entry = along - inside
        if along + inside <= 0.0:
            continue  # behind
        first = min(first, max(entry, 0.0))
    return first


@kernel
def way_round(a, m, x, y, gx, gy, look, positions, radii, moving):
    """(way_x, way_y, found): the direction of the fan beside (gx, gy) nearest it that is free for `look`,
    the side found last tried first (kept in m)."""
    angle = math.atan2(gy, gx)
    first = m[R_WAY_SIDE] if m[R_WAY_SIDE] != 0.0 else 1.0
    inflate = a[A_ROBOT_RADIUS] + a[A_FREE_MARGIN]
    for k in range(1, int(a[A_WAY_FAN_STEPS]) + 1):
        for turn in range(2):
            sign = first if turn == 0 else -first
            ux = math.cos(angle + sign * k * a[A_WAY_FAN_STEP])
            uy = math.sin(angle + sign * k * a[A_WAY_FAN_STEP])
            if ray_clearance(x, y, ux, uy, positions, radii, inflate, look, moving, False) >= look:
                m[R_WAY_SIDE] = sign
                return ux, uy, True
    return gx, gy, False


@kernel
def field(a, m, x, y, yaw, vx, vy, target_x, target_y, target_vx, target_vy, distance, positions, radii,
          distances, moving):
    """The field's direction: (f_att_x, f_att_y, f_rep_x, f_rep_y, gx, gy, blocked_at, way_x, way_y, way_free,
    total_x, total_y); g the attraction's unit direction, blocked_at where the straight way is blocked
    (distance when free), way the direction that carries the attraction, total the field's sum."""
    f_att_x, f_att_y = attraction(x, y, vx, vy, target_x, target_y, target_vx, target_vy, a[A_K_P], a[A_K_V])
    fade = 1.0
    if a[A_GOAL_FADE] > 0.0:
        fade = min(1.0, (distance / a[A_GOAL_FADE]) ** 2)
    f_rep_x, f_rep_y = repulsion(x, y, positions, radii, a[A_K_O], a[A_REPULSION_RANGE], a[A_ROBOT_RADIUS],
                                  a[A_MIN_DISTANCE], distances, fade)
    # is the straight way to the target free (every obstacle where it is now, footprint and a margin)?
    att_norm = math.hypot(f_att_x, f_att_y)
    gx = f_att_x / att_norm if att_norm > 1e-12 else math.cos(yaw)
    gy = f_att_y / att_norm if att_norm > 1e-12 else math.sin(yaw)
    blocked_at = ray_clearance(x, y, gx, gy, positions, radii, a[A_ROBOT_RADIUS] + a[A_FREE_MARGIN], distance,
                               moving, False)
    look = min(distance, a[A_WAY_LOOK])
    way_x = gx
    way_y = gy
    way_free = blocked_at >= look  # free to the target, or far enough (look <= distance)
    if not way_free:
        way_x, way_y, way_free = way_round(a, m, x, y, gx, gy, look, positions, radii, moving)
    if way_free:
        # The way is free: the repulsion steers (at most free_steer of the attraction), it neither holds the
        # robot back nor turns it away from a target it can drive to.
        along = f_rep_x * way_x + f_rep_y * way_y
        if along < 0.0:
            f_rep_x -= along * way_x
            f_rep_y -= along * way_y
        ratio = math.hypot(f_rep_x, f_rep_y) / max(att_norm, 1e-12)
        if ratio > a[A_FREE_STEER]:
            f_rep_x *= a[A_FREE_STEER] / ratio
            f_rep_y *= a[A_FREE_STEER] / ratio
    total_x = att_norm * way_x + f_rep_x
    total_y = att_norm * way_y + f_rep_y
    return f_att_x, f_att_y, f_rep_x, f_rep_y, gx, gy, blocked_at, way_x, way_y, way_free, total_x, total_y
