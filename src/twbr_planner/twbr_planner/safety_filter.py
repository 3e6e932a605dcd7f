"""Robust addition 5, the safety filter: a control barrier function per obstacle on a point
`safety_lookahead` ahead of the axle (where both v and omega act), h = |q - p_j|^2 - R_j^2, requiring
dh/dt + safety_gamma h >= 0 with the obstacle's velocity (Ames et al. 2019). The admissible (v, omega)
nearest the command, within the acceleration limits of one planning period, is chosen among a grid of
safety_speed_samples x safety_yaw_rate_samples candidates (or, when none is admissible, the one that
violates least)."""

from __future__ import annotations

import math

from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_BRAKE_DECELERATION,
    A_MAX_ACCELERATION,
    A_RHO_O,
    A_ROBOT_RADIUS,
    A_SAFETY_GAMMA,
    A_SAFETY_LOOKAHEAD,
    A_SAFETY_MARGIN,
    A_SAFETY_MOVING_NEAR,
    A_SAFETY_SPEED_SAMPLES,
    A_SAFETY_YAW_RATE_SAMPLES,
    A_SAFETY_YAW_RATE_WEIGHT,
    A_V_MAX,
    R_LAST_V,
    command_period,
    yaw_rate_window,
)

VIOLATION_TIE = 1e-6  # [m^2/s] violations this close count as equal (rounding, not a tuning)


@kernel
def safety_filter(a, stamp, m, x, y, yaw, v_nominal, omega_nominal, positions, velocities, radii, threat, jerk):
    """(v, omega, index of the binding obstacle or -1): the admissible command nearest the nominal one.

    The obstacle being evaded (`threat`, -1 none) is left to the evasion: a barrier on the distance alone
    would steer along a fast obstacle's path (away from it, for now) instead of out of it."""
    dt = command_period(m, stamp)
    n_v = int(a[A_SAFETY_SPEED_SAMPLES])
    n_w = int(a[A_SAFETY_YAW_RATE_SAMPLES])
    # it reverses only when the command does (and then guards the point behind the axle)
    v_lo = max(m[R_LAST_V] - a[A_BRAKE_DECELERATION] * dt, min(0.0, v_nominal), -a[A_V_MAX])
    v_hi = min(m[R_LAST_V] + a[A_MAX_ACCELERATION] * dt, a[A_V_MAX])
    v_lo = min(v_lo, v_hi)  # a robot still reversing slows down first
    w_lo, w_hi = yaw_rate_window(a, m, dt, jerk)
    v0 = min(max(v_nominal, v_lo), v_hi)
    w0 = min(max(omega_nominal, w_lo), w_hi)
    v_nominal = float(v_nominal)
    omega_nominal = float(omega_nominal)
    ex = math.cos(yaw)
    ey = math.sin(yaw)
    look = a[A_SAFETY_LOOKAHEAD] if v_nominal >= 0.0 else -a[A_SAFETY_LOOKAHEAD]
    qx = x + look * ex
    qy = y + look * ey
    gamma = a[A_SAFETY_GAMMA]
    # Each obstacle in range gives a constraint linear in the command: cv * A + cw * B + C >= 0; a robot
    # turning on the spot moves no part of its round footprint, so a command with cv = 0 is held to the
    # axle's own barrier D >= 0 instead (the point ahead would forbid the turn that leaves a boundary).
    # They are kept as (A, B, C, D, obstacle) tuples of floats: the same arithmetic compiled, and in the
    # interpreted node (TWBR_JIT=off) the candidate grid below works on Python floats, not numpy elements
    # (its time sits in the navigation graph's control latency at every plan: benchmarks/README.md).
    constraints = []
    n = radii.shape[0]
    for j in range(n):
        if j == threat:
            continue
        rx = qx - positions[j, 0]
        ry = qy - positions[j, 1]
        reach = radii[j] + a[A_ROBOT_RADIUS] + a[A_SAFETY_MARGIN]
        centre = math.sqrt(rx * rx + ry * ry)
        if centre - reach > a[A_RHO_O]:
            continue  # beyond the detection range
        if centre - reach > a[A_SAFETY_MOVING_NEAR] and math.hypot(velocities[j, 0], velocities[j, 1]) > a[A_V_MAX]:
            # an obstacle faster than the robot is left to the evasion until it is near: a barrier on its
            # distance would turn the robot away from it, along its path, where it cannot outrun it
            continue
        px = x - positions[j, 0]
        py = y - positions[j, 1]
        constraints.append((
            float(2.0 * (rx * ex + ry * ey)),
            float(2.0 * look * (ry * ex - rx * ey)),
            float(-2.0 * (rx * velocities[j, 0] + ry * velocities[j, 1]) + gamma * (centre * centre - reach * reach)),
            float(-2.0 * (px * velocities[j, 0] + py * velocities[j, 1]) + gamma * (px * px + py * py - reach * reach)),
            j,
        ))
    if len(constraints) == 0:
        return v0, w0, -1
    best_v = v0
    best_w = w0
    best_cost = math.inf
    best_violation = math.inf
    best_binding = -1
    for i in range(n_v + 1):
        cv = float(v0 if i == n_v else v_lo + (v_hi - v_lo) * i / (n_v - 1))
        for k in range(n_w + 1):
            cw = float(w0 if k == n_w else w_lo + (w_hi - w_lo) * k / (n_w - 1))
            violation = 0.0
            slack = math.inf
            binding = -1
            for along, turn, const, axle, j in constraints:
                s = axle if cv == 0.0 else cv * along + cw * turn + const
                if s < 0.0:
                    violation -= s
                if s < slack:
                    slack = s
                    binding = j
            v_change = cv - v_nominal
            w_change = cw - omega_nominal
            cost = v_change * v_change + a[A_SAFETY_YAW_RATE_WEIGHT] * (w_change * w_change)
            # the least total violation (none: admissible), and among equals the nearest the nominal command;
            # a constraint no candidate can help (a wall straight ahead while braking) leaves the steering free
            if violation < best_violation - VIOLATION_TIE or (
                    violation <= best_violation + VIOLATION_TIE and cost < best_cost):
                best_v = cv
                best_w = cw
                best_cost = cost
                best_violation = min(violation, best_violation)
                best_binding = binding
    changed = abs(best_v - v0) > 1e-12 or abs(best_w - w0) > 1e-12
    return best_v, best_w, best_binding if changed else -1
