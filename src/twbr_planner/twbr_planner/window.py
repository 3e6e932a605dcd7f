"""Robust addition 7, the dynamic window among moving obstacles: where people are near, the field's direction is
driven the way the dynamic window approach drives to its target (Fox, Burgard & Thrun 1997).

The field steers along the present forces and the speed policy brakes for what is ahead; among walkers that
makes a slow robot that lingers in their lanes (clutter with movers: half the median speed of the dynamic
window, and twice its collisions). Here, while a moving obstacle can come within reach over `window_horizon`,
a grid of (v, omega) commands is rolled out at the acceleration limits against every obstacle on its line
and on its predicted path (prediction.py; dwa.rollout) and scored as Fox et al. score theirs, with the
heading measured to the field's direction instead of the target's (the field keeps its escape from local minima and its evasion):
window_heading_weight * heading + window_clearance_weight * clearance (capped at window_clearance_cap) +
window_speed_weight * speed. A rollout within window_margin of an obstacle is not admissible (wider than the
safety filter's margin, whose barrier does not run beside it); when none is (tight quarters), the field's
command and the safety filter stand. The yield step still judges the command it picks; the safety filter
does not (robust.py): its barrier on a walker's distance brakes the robot in the walker's way."""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_CAPTURE_RADIUS,
    A_MAX_ACCELERATION,
    A_V_MAX,
    A_WINDOW_ACCELERATION,
    A_WINDOW_CLEARANCE_CAP,
    A_WINDOW_CLEARANCE_WEIGHT,
    A_WINDOW_HEADING_WEIGHT,
    A_WINDOW_HORIZON,
    A_WINDOW_LANE_ANGLE,
    A_WINDOW_MARGIN,
    A_WINDOW_MIN_SPEED,
    A_WINDOW_SPEED_WEIGHT,
    R_LAST_OMEGA,
    R_LAST_V,
    top_speed,
)
from twbr_planner.dwa import (
    OMEGA_SAMPLES,
    ROLLOUT_STEP,
    V_SAMPLES,
    candidate,
    end_yaw,
    gap_table,
    objective,
    rollout_among,
    within_reach,
)
from twbr_planner.prediction import MOVING, hypotheses
from twbr_planner.yielding import in_reach


@kernel
def window_acts(a, x, y, positions, velocities, radii):
    """Whether the window drives: a walker-fast obstacle can come near within window_horizon (and it is on)."""
    horizon = a[A_WINDOW_HORIZON]
    return horizon > 0.0 and in_reach(a, x, y, positions, velocities, radii, horizon,
                                      max(a[A_WINDOW_MIN_SPEED], MOVING), 0.0, 0.0)


@kernel
def window_limits(a, x, y, positions, velocities, radii, arrived):
    """The settings the rest of the step plans and limits its command with: while the window acts the speed
    may rise at window_acceleration (its rollouts, the yielding's and the rate limits all read
    max_acceleration from them); else `a` itself. A person not looking out walks at 0.5 m/s into a robot
    that needs 10 s to reach 0.6 m/s at max_acceleration (benchmarks/HISTORY.md, twenty-eighth session)."""
    if arrived or a[A_WINDOW_ACCELERATION] <= a[A_MAX_ACCELERATION] or not window_acts(a, x, y, positions,
                                                                                          velocities, radii):
        return a
    b = a.copy()
    b[A_MAX_ACCELERATION] = a[A_WINDOW_ACCELERATION]
    return b


@kernel
def window_direction(a, alpha, field_x, field_y, threat, velocities):
    """[rad] the direction the window scores its rollouts' headings against: the field's with the evasion's
    push (`alpha`), or without it (field_x, field_y: the field before the evasion) while the threat walks
    within window_lane_angle of that way, towards the robot or after it. The push steps the robot across the
    way; in a flow of people it crossed their lanes one after another and backed away from people who would
    have given way (people_flow: 1.27x the dynamic window's median time; benchmarks/HISTORY.md,
    twenty-ninth session). Walkers crossing the way keep the push: without it clutter_movers lost 9
    points."""
    if threat < 0:
        return alpha
    walk_x = velocities[threat, 0]
    walk_y = velocities[threat, 1]
    norms = math.hypot(field_x, field_y) * math.hypot(walk_x, walk_y)
    across = abs(field_x * walk_y - field_y * walk_x)  # norms x |sin| of the angle between walk and way
    if norms > 0.0 and across < math.sin(a[A_WINDOW_LANE_ANGLE]) * norms:
        return math.atan2(field_y, field_x)
    return alpha


@kernel
def heading_error(a, alpha, eyaw, closest, distance, arriving):
    """[rad] a rollout's heading term: its end heading against the field's direction `alpha`; while
    `arriving`, how little of the way into the capture radius its closest approach to the target [m] leaves
    (pi: none of it, 0: it arrives)."""
    if not arriving:
        return alpha - eyaw
    capture = a[A_CAPTURE_RADIUS]
    return math.pi * min(max((closest - capture) / max(distance - capture, 1e-9), 0.0), 1.0)


@kernel
def window_command(a, m, x, y, yaw, v_nominal, omega_nominal, alpha, target_x, target_y, distance, moving_target,
                   positions, velocities, radii, paths):
    """(v, omega, windowed): the best-scoring admissible rollout towards the field's direction `alpha` [rad]
    while a moving obstacle is in reach; else (or with none admissible) the field's command. A static target
    within a rollout's reach is scored by how near each rollout comes to it: the direction at the start says
    nothing of that, and rollouts scored by it circle the target among walkers (people_flow,
    benchmarks/HISTORY.md)."""
    if not window_acts(a, x, y, positions, velocities, radii):
        return v_nominal, omega_nominal, False
    horizon = a[A_WINDOW_HORIZON]
    v0 = m[R_LAST_V]
    w0 = m[R_LAST_OMEGA]
    cap = a[A_WINDOW_CLEARANCE_CAP]
    v_top = top_speed(a, distance, moving_target)
    arriving = not moving_target and distance <= v_top * horizon
    goal_x = target_x if arriving else math.nan  # the rollouts' closest approach to it is read only then
    goal_y = target_y if arriving else math.nan
    beyond = max(cap, a[A_WINDOW_MARGIN])
    near = within_reach(a, x, y, v0, positions, velocities, radii, horizon, beyond)
    near_r = radii[near]
    samples = hypotheses(positions[near], velocities[near], paths[near], horizon, ROLLOUT_STEP)
    steps_near, steps_count = gap_table(a, x, y, v0, samples, near_r, beyond)
    best_score = -math.inf
    best_v = v_nominal
    best_w = omega_nominal
    weights = (a[A_WINDOW_HEADING_WEIGHT], a[A_WINDOW_CLEARANCE_WEIGHT], a[A_WINDOW_SPEED_WEIGHT])
    # a rollout's end heading depends on its yaw rate alone: the most a candidate can score is at its
    # heading (arriving: at none off) with the clearance at the cap, and one that cannot beat the best is
    # not rolled out
    end_yaws = np.empty(OMEGA_SAMPLES)
    for k in range(OMEGA_SAMPLES):
        end_yaws[k] = alpha if arriving else end_yaw(a, yaw, w0, candidate(a, v_top, 0, k)[1], horizon)
    for i in range(V_SAMPLES):
        for k in range(OMEGA_SAMPLES):
            v_goal, w_goal = candidate(a, v_top, i, k)
            if objective(*weights, cap, alpha - end_yaws[k], cap, v_goal, a[A_V_MAX]) <= best_score:
                continue
            clearance, contact, _, _, eyaw, closest = rollout_among(a, x, y, yaw, v0, w0, v_goal, w_goal, samples,
                                                                    near_r, steps_near, steps_count, horizon,
                                                                    a[A_WINDOW_MARGIN], True, goal_x, goal_y)
            if contact < math.inf:
                continue  # not admissible (its rollout stopped there)
            score = objective(*weights, cap, heading_error(a, alpha, eyaw, closest, distance, arriving), clearance,
                              v_goal, a[A_V_MAX])
            if score > best_score:
                best_score = score
                best_v = v_goal
                best_w = w_goal
    if best_score == -math.inf:
        # no rollout stays clear: tight quarters, where the field and the safety filter's barriers drive
        return v_nominal, omega_nominal, False
    return best_v, best_w, True
