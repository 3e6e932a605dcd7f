"""Robust addition 3, evasion (after Ge & Cui 2002's dynamic repulsion): a moving obstacle whose closest
approach, at the current relative velocity, comes within `evade_margin` of the robot's footprint in less
than `evade_horizon` pushes the robot sideways out of its swept path, early, instead of braking in it."""

from __future__ import annotations

import math

from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_EVADE_GAIN,
    A_EVADE_HORIZON,
    A_EVADE_MARGIN,
    A_EVADE_SWITCH,
    A_MAX_ACCELERATION,
    A_ROBOT_RADIUS,
    A_V_MAX,
    R_EVADE_SIDE,
    R_EVADE_THREAT,
)


@kernel
def reachable_distance(speed, tau, acceleration, v_max):
    """[m] the robot drives in tau [s] from `speed`, accelerating at `acceleration` up to v_max."""
    speed = min(abs(speed), v_max)
    t_top = (v_max - speed) / acceleration
    if tau <= t_top:
        return speed * tau + 0.5 * acceleration * tau * tau
    return (v_max * v_max - speed * speed) / (2.0 * acceleration) + v_max * (tau - t_top)


@kernel
def closest_approach(x, y, vx, vy, position, velocity):
    """(tau [s], miss [m], out_x, out_y): when the robot, at its velocity relative to a moving obstacle's,
    passes it closest, how close (centre to centre), and the unit direction from the obstacle to the robot
    then, the way that widens the miss (Ge & Cui's dynamic repulsion acts along it); tau = inf when they
    do not approach."""
    px = x - position[0]
    py = y - position[1]
    wx = vx - velocity[0]
    wy = vy - velocity[1]
    ww = wx * wx + wy * wy
    if ww < 1e-9:
        return math.inf, math.hypot(px, py), 0.0, 0.0
    tau = -(px * wx + py * wy) / ww
    if tau <= 0.0:
        return math.inf, math.hypot(px, py), 0.0, 0.0
    cx = px + wx * tau
    cy = py + wy * tau
    miss = math.hypot(cx, cy)
    if miss > 1e-3:
        return tau, miss, cx / miss, cy / miss
    speed = math.sqrt(ww)
    return tau, miss, wy / speed, -wx / speed  # dead on: pass it on the right of the relative motion


@kernel
def evasion(a, m, x, y, vx, vy, positions, velocities, radii, moving):
    """Ge & Cui's dynamic repulsion, as a direction: the sum over threatening moving obstacles of the
    direction that widens the closest approach, each weighted by its urgency (the distance the miss lacks,
    times evade_gain, over the distance the robot can drive before the closest approach, at most 1); the
    most urgent one's index (-1 none) and its own widening direction.

    An obstacle coming nearly dead on is passed on the side chosen when it first became the most urgent
    (kept in m) until the other side is evade_switch clearer: the widening direction flips as the miss
    crosses zero, and a robot that follows each flip brakes and speeds up in the obstacle's path."""
    horizon = a[A_EVADE_HORIZON]
    ex = 0.0
    ey = 0.0
    threat = -1
    threat_x = 0.0
    threat_y = 0.0
    threat_side = 0.0
    urgent = 0.0
    if horizon <= 0.0:
        m[R_EVADE_SIDE] = 0.0
        return ex, ey, threat, threat_x, threat_y
    drive_speed = math.hypot(vx, vy)
    for j in range(radii.shape[0]):
        if not moving[j]:
            continue
        tau, miss, out_x, out_y = closest_approach(x, y, vx, vy, positions[j], velocities[j])
        reach = radii[j] + a[A_ROBOT_RADIUS] + a[A_EVADE_MARGIN]
        if tau > horizon or miss >= reach:
            continue
        # the side of the relative motion it passes on: +1 its right, -1 its left
        side = 1.0 if out_x * (vy - velocities[j, 1]) - out_y * (vx - velocities[j, 0]) >= 0.0 else -1.0
        if (j == m[R_EVADE_THREAT] and m[R_EVADE_SIDE] != 0.0 and side != m[R_EVADE_SIDE]
                and miss < a[A_EVADE_SWITCH]):
            out_x = -out_x
            out_y = -out_y
            miss = -miss
            side = -side
        drivable = reachable_distance(drive_speed, tau, a[A_MAX_ACCELERATION], a[A_V_MAX])
        weight = min(1.0, a[A_EVADE_GAIN] * (reach - miss) / max(drivable, 1e-6))
        ex += weight * out_x
        ey += weight * out_y
        if weight > urgent:
            urgent = weight
            threat = j
            threat_x = out_x
            threat_y = out_y
            threat_side = side
    m[R_EVADE_THREAT] = threat
    m[R_EVADE_SIDE] = threat_side
    return ex, ey, threat, threat_x, threat_y


@kernel
def evade(a, m, x, y, vx, vy, total_x, total_y, positions, velocities, radii, moving):
    """(total_x, total_y, threat): the direction blended with the way out of the most urgent threat's path,
    never towards the obstacle nor so as to narrow its closest approach; threat -1 when none (unchanged)."""
    ex, ey, threat, out_x, out_y = evasion(a, m, x, y, vx, vy, positions, velocities, radii, moving)
    if threat < 0:
        return total_x, total_y, threat
    norm = math.hypot(total_x, total_y)
    base_x = total_x / norm if norm > 1e-12 else 0.0
    base_y = total_y / norm if norm > 1e-12 else 0.0
    to_x = positions[threat, 0] - x
    to_y = positions[threat, 1] - y
    to_norm = max(math.hypot(to_x, to_y), 1e-9)
    towards = (base_x * to_x + base_y * to_y) / to_norm
    if towards > 0.0:
        base_x -= towards * to_x / to_norm
        base_y -= towards * to_y / to_norm
    inwards = base_x * out_x + base_y * out_y
    if inwards < 0.0:
        base_x -= inwards * out_x
        base_y -= inwards * out_y
    urgency = min(1.0, math.hypot(ex, ey))
    return (1.0 - urgency) * base_x + ex, (1.0 - urgency) * base_y + ey, threat
