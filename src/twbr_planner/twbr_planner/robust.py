"""The robust potential-field planner (`method: robust`): the paper's field, and what its failures call for.

It keeps the paper's attraction (eq. 21) and repulsion (eq. 23) and steers along their sum, with eight
additions, one module each (docs/planner.md says where each comes from), each switched off by one parameter
for the ablation study, in the manner of Nav2 MPPI's critics:

1. field.py: goal-reachable repulsion within repulsion_range, and a way round a blocked straight way;
2. escape.py: out of local minima down a navigation function, or along the boundary (follow_range);
3. evasion.py: out of a moving obstacle's swept path, early (evade_horizon);
4. speed_policy.py: the yaw rate, and a speed that can stop before what is ahead (speed_policy);
5. yielding.py: a look-ahead over the predicted motion that waits, steps aside or backs out (yield_horizon);
6. safety_filter.py: a control barrier function per obstacle (safety_filter);
7. window.py: among moving obstacles, the field's direction driven by a dynamic window (window_horizon),
   in place of the safety filter;
8. prediction.py: the paths the window's and the yielding's rollouts expect the moving obstacles on, bent
   round the static discs as people walk (prediction_strength).

This module only composes them; everything is compiled and shared with the batch engine, like the paper's
`apf_step`.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_BRAKE_DECELERATION,
    A_EVASION_YAW_JERK,
    A_MAX_YAW_JERK,
    A_PREDICTION_RANGE,
    A_PREDICTION_RELAXATION_TIME,
    A_PREDICTION_STRENGTH,
    A_RHO_O,
    A_SAFETY_FILTER,
    A_V_MAX,
    A_WINDOW_HORIZON,
    A_YIELD_HORIZON,
    AVOIDING,
    ESCAPING,
    EVADING,
    FOLLOWING,
    R_FOLLOWING,
    R_STALLED,
    STUCK,
    TRACKING,
    YIELDING,
    arrive,
    limit_rates,
    nearest_obstacle,
    no_progress,
    write_output,
)
from twbr_planner.escape import escape
from twbr_planner.evasion import evade
from twbr_planner.field import field
from twbr_planner.prediction import predict_paths
from twbr_planner.safety_filter import safety_filter
from twbr_planner.speed_policy import speed, steer
from twbr_planner.window import window_acts, window_command, window_direction, window_limits
from twbr_planner.yielding import yield_acts, yield_command


@kernel
def predicted(a, x, y, positions, velocities, radii, arrived):
    """The moving obstacles' predicted paths (8.) over the window's and the yielding's horizons, computed only
    when one of them will roll out against them (else a table of zeros, never read)."""
    if not arrived and (window_acts(a, x, y, positions, velocities, radii)
                        or yield_acts(a, x, y, positions, velocities, radii)):
        return predict_paths(positions, velocities, radii, max(a[A_WINDOW_HORIZON], a[A_YIELD_HORIZON]),
                             a[A_PREDICTION_STRENGTH], a[A_PREDICTION_RANGE], a[A_PREDICTION_RELAXATION_TIME])
    return np.zeros((radii.shape[0], 2, 2))


@kernel
def robust_step(a, m, ring, out, stamp, x, y, yaw, speed_now, target_x, target_y, target_vx, target_vy, positions,
                velocities, radii, distances):
    """One planning step of the robust method into `out` (Q_*)."""
    vx = speed_now * math.cos(yaw)
    vy = speed_now * math.sin(yaw)
    distance = math.hypot(target_x - x, target_y - y)
    moving_target = math.hypot(target_vx, target_vy) > 1e-3
    moving = np.empty(radii.shape[0], dtype=np.bool_)
    for j in range(radii.shape[0]):
        moving[j] = math.hypot(velocities[j, 0], velocities[j, 1]) > 1e-3
    # 1. the field (it fills `distances`), 2. the escape in its place out of a local minimum, 3. evasion
    (f_att_x, f_att_y, f_rep_x, f_rep_y, gx, gy, blocked_at, way_x, way_y, way_free, total_x,
     total_y) = field(a, m, x, y, yaw, vx, vy, target_x, target_y, target_vx, target_vy, distance, positions, radii,
                      distances, moving)
    nearest, nearest_d = nearest_obstacle(distances)
    mode = AVOIDING if nearest_d <= a[A_RHO_O] else TRACKING
    total_x, total_y, side, escaping = escape(a, m, stamp, x, y, distance, moving_target, target_x, target_y, gx, gy,
                                              way_x, way_y, way_free, blocked_at, total_x, total_y, positions, radii,
                                              moving)
    if escaping:
        mode = ESCAPING
    field_x, field_y = total_x, total_y
    total_x, total_y, threat = evade(a, m, x, y, vx, vy, total_x, total_y, positions, velocities, radii, moving)
    if threat >= 0:
        mode = EVADING
    # 4. the command
    alpha, error, omega, direction = steer(a, m, yaw, total_x, total_y, threat)
    v = speed(a, x, y, yaw, error, direction, threat, positions, radii, moving, nearest_d)
    mode, v, omega, arrived = arrive(a, m, distance, moving_target, mode, v, omega)
    if arrived:
        m[R_FOLLOWING] = 0.0
    else:
        m[R_STALLED] = 0.0
        if mode != FOLLOWING and no_progress(a, m, ring, stamp, distance, x, y, moving_target):
            mode = STUCK
            m[R_STALLED] = 1.0  # the next step follows the boundary, if there is one
    # 7. among moving obstacles, the field's direction driven by a dynamic window; 5. yielding to what the
    # look-ahead sees coming, 6. the safety filter, then the acceleration limits
    windowed = False
    paths = predicted(a, x, y, positions, velocities, radii, arrived)
    a = window_limits(a, x, y, positions, velocities, radii, arrived)
    # an obstacle faster than the robot being evaded is left to the evasion: no rollout outruns it
    outrun = threat >= 0 and math.hypot(velocities[threat, 0], velocities[threat, 1]) > a[A_V_MAX]
    if not arrived and not outrun:
        v, omega, windowed = window_command(a, m, x, y, yaw, v, omega,
                                            window_direction(a, alpha, field_x, field_y, threat, velocities),
                                            target_x, target_y, distance, moving_target, positions, velocities,
                                            radii, paths)
    if not arrived:
        v, omega, yielding = yield_command(a, m, x, y, yaw, v, omega, target_x, target_y, positions, velocities,
                                           radii, paths)
        if yielding:
            mode = YIELDING
    # the yaw jerk limit rounds the turns of ordinary driving; out of a threat's path, its own (steeper) limit
    jerk = a[A_MAX_YAW_JERK] if threat < 0 else a[A_EVASION_YAW_JERK]
    binding = -1
    # the window's rollouts judged its command against every obstacle's motion: the barriers would brake the
    # robot where the window chose to drive on (in a walker's way; kept for the static discs alone, they
    # halved clutter_movers' success: benchmarks/HISTORY.md)
    if a[A_SAFETY_FILTER] != 0.0 and not arrived and not windowed:
        v, omega, binding = safety_filter(a, stamp, m, x, y, yaw, v, omega, positions, velocities, radii, threat,
                                          jerk)
    v, omega = limit_rates(a, m, stamp, v, omega, a[A_BRAKE_DECELERATION], jerk)
    write_output(out, f_att_x, f_att_y, f_rep_x, f_rep_y, alpha, error, v, omega, distance, nearest_d, nearest, mode,
                 side, threat, binding)
