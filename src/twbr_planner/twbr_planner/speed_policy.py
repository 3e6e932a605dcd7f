"""Robust addition 4, the command from the direction: the yaw rate (the paper's eq. 27, with two rules for a
way behind the robot) and a speed policy for a robot that must lean to brake.

The speed is at most the one from which `brake_deceleration` stops the robot before the first obstacle
ahead and before the first one in the direction it turns to, and it is never slowed by a moving obstacle
being evaded (braking in its path is what evasion avoids). speed_policy: false gives eq. 28."""

from __future__ import annotations

import math

from twbr_common.geometry import wrap_angle
from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_BEHIND_ANGLE,
    A_BRAKE_DECELERATION,
    A_K_S,
    A_MAX_YAW_RATE,
    A_REVERSE_BELOW,
    A_RHO_O,
    A_ROBOT_RADIUS,
    A_SAFETY_MARGIN,
    A_SLOW_IN_TURNS,
    A_SPEED_POLICY,
    A_TURNING_YAW_RATE,
    A_V_MAX,
    R_LAST_OMEGA,
    R_LAST_V,
)
from twbr_planner.field import ray_clearance


@kernel
def steer(a, m, yaw, total_x, total_y, threat):
    """(alpha, error, omega, direction): the desired heading, the heading error, the yaw rate (eq. 27) and
    +1 forward / -1 backing away from a threat whose way out is behind a (nearly) stopped robot."""
    alpha = math.atan2(total_y, total_x)
    error = wrap_angle(alpha - yaw)
    # Out of a threat's path a robot that is (nearly) stopped backs away when the way out is behind it,
    # instead of turning on the spot first; one that drives on turns while it drives.
    direction = 1.0
    if threat >= 0 and abs(error) > 0.5 * math.pi and m[R_LAST_V] < a[A_REVERSE_BELOW]:
        direction = -1.0
        error = wrap_angle(error + math.pi)
    # A way nearly behind is turned to the way the robot already turns: either way round is as short, and
    # a heading error dithering about +-pi (an evasion that nearly cancels the field) would reverse the
    # turn at every step.
    if abs(error) > a[A_BEHIND_ANGLE] and m[R_LAST_OMEGA] * error < 0.0 and abs(m[R_LAST_OMEGA]) > a[A_TURNING_YAW_RATE]:
        error -= math.copysign(2.0 * math.pi, error)
    omega = min(max(a[A_K_S] * error, -a[A_MAX_YAW_RATE]), a[A_MAX_YAW_RATE])
    return alpha, error, omega, direction


@kernel
def speed(a, x, y, yaw, error, direction, threat, positions, radii, moving, nearest_d):
    """[m/s] the signed speed command before arrival, yielding and the safety filter."""
    v = a[A_V_MAX]
    if a[A_SLOW_IN_TURNS] != 0.0 and not (threat >= 0 and abs(error) < 0.5 * math.pi):
        v *= max(0.0, math.cos(error))  # turn before driving, except out of a threat's path
    if a[A_SPEED_POLICY] != 0.0:
        # able to stop before the first obstacle ahead and before the first one the way it turns to (a moving
        # obstacle being evaded does not slow the robot down); a disc beside the way does not slow it: the
        # safety filter keeps the robot from turning into it
        reach = a[A_RHO_O] * 4.0
        skip_moving = threat >= 0
        ahead = ray_clearance(x, y, direction * math.cos(yaw), direction * math.sin(yaw), positions, radii,
                              a[A_ROBOT_RADIUS], reach, moving, skip_moving)
        turn_to = ray_clearance(x, y, direction * math.cos(yaw + error), direction * math.sin(yaw + error), positions,
                                radii, a[A_ROBOT_RADIUS], reach, moving, skip_moving)
        room = min(ahead, turn_to) - a[A_SAFETY_MARGIN]
        v = min(v, math.sqrt(2.0 * a[A_BRAKE_DECELERATION] * max(room, 0.0)))
    else:
        v = min(v, a[A_V_MAX] * max(min(nearest_d, a[A_RHO_O]), 0.0) / a[A_RHO_O])  # eq. 28
    return v * direction
