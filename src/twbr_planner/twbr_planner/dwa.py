"""The dynamic window approach (`method: dwa`), a baseline peer of the robust method.

Fox, Burgard & Thrun (1997), "The dynamic window approach to collision avoidance", IEEE Robotics &
Automation Magazine 4(1). Each planning step scores a grid of (v, omega) commands by rolling each out
over `dwa_horizon` seconds and keeps the best:

    G(v, omega) = dwa_heading_weight * heading + dwa_clearance_weight * clearance + dwa_speed_weight * velocity

heading: 1 - |angle from the rollout's end pose to the target| / pi; clearance: the smallest footprint
clearance along the rollout, capped at `dwa_clearance_cap`, over the cap; velocity: the rollout's speed
over v_max (Fox's three terms, each normalised to [0, 1]). A rollout that comes within `safety_margin` of
an obstacle is not admissible (Fox's admissible velocities: the robot could not stop before it); when
none is, the one whose contact comes last is taken. As in ROS's trajectory rollout, each rollout reaches
its (v, omega) at the robot's acceleration limits (max_acceleration, brake_deceleration,
max_yaw_acceleration) from the last command, so the window is what the robot can reach over the horizon
and the rollout is the path it would drive. Obstacles move at their constant velocity along each rollout.
The same limits, arrival and stuck report as the other methods; compiled, shared with the batch engine.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.geometry import wrap_angle
from twbr_common.jit import inline_kernel, kernel
from twbr_planner.apf import (
    A_DWA_CLEARANCE_CAP,
    A_DWA_CLEARANCE_WEIGHT,
    A_DWA_HEADING_WEIGHT,
    A_DWA_HORIZON,
    A_DWA_SPEED_WEIGHT,
    A_MAX_YAW_ACCELERATION,
    A_MAX_YAW_RATE,
    A_ROBOT_RADIUS,
    A_SAFETY_MARGIN,
    A_V_MAX,
    R_LAST_OMEGA,
    R_LAST_V,
    ramp_speed,
    sampling_finish,
    sampling_start,
    top_speed,
)
from twbr_planner.prediction import nearer_distance2, reachable, straight_hypotheses

V_SAMPLES = 7  # forward speeds from 0 to v_max
OMEGA_SAMPLES = 31  # yaw rates from -max_yaw_rate to max_yaw_rate (0.1 rad/s apart by default: the heading
# at a rollout's end must be able to settle on the target's)
ROLLOUT_STEP = 0.2  # [s]


@inline_kernel
def drive(a, x, y, yaw, v, w, v_goal, w_goal, dt):
    """(x, y, yaw, v, w) after dt [s] towards (v_goal, w_goal) at the acceleration limits (the speed as
    ramp_speed, the yaw rate within max_yaw_acceleration): every rollout's robot, the window's and the
    yielding's alike."""
    v = ramp_speed(a, v, v_goal, dt)
    yaw, w = turn(a, yaw, w, w_goal, dt)
    return x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt, yaw, v, w


@inline_kernel
def turn(a, yaw, w, w_goal, dt):
    """(yaw, w) after dt [s] towards w_goal within max_yaw_acceleration: a rollout's heading, which its speed
    and the obstacles do not change."""
    dw = a[A_MAX_YAW_ACCELERATION] * dt
    w = min(max(w_goal, w - dw), w + dw)
    return yaw + w * dt, w


@kernel
def end_yaw(a, yaw, w0, w_goal, horizon):
    """[rad] a rollout's heading at the end of `horizon` [s] (as `rollout` turns it), without driving it."""
    w = w0
    for _ in range(max(1, int(horizon / ROLLOUT_STEP + 0.5))):
        yaw, w = turn(a, yaw, w, w_goal, ROLLOUT_STEP)
    return yaw


@kernel
def candidate(a, v_top, i, k):
    """The grid's (v, omega) number (i, k): forward speeds from 0 to v_top [m/s], yaw rates across
    +-max_yaw_rate."""
    return v_top * i / (V_SAMPLES - 1), a[A_MAX_YAW_RATE] * (2.0 * k / (OMEGA_SAMPLES - 1) - 1.0)


@kernel
def within_reach(a, x, y, v0, positions, velocities, radii, horizon, beyond):
    """The indices of the obstacles that a rollout from (x, y) [m] starting at v0 [m/s] may
    bring within `beyond` [m] over `horizon` [s]: the others can change neither a rollout's admissibility
    nor its clearance capped at `beyond`, and skipping them makes the same choice at a fraction of the cost
    in clutter (benchmarks/bench_planner.py)."""
    travel = max(abs(v0), a[A_V_MAX]) * horizon
    keep = np.empty(radii.shape[0], dtype=np.int64)
    count = 0
    for j in range(radii.shape[0]):
        reach = travel + math.hypot(velocities[j, 0], velocities[j, 1]) * horizon + beyond + 1e-6
        if math.hypot(positions[j, 0] - x, positions[j, 1] - y) - radii[j] - a[A_ROBOT_RADIUS] <= reach:
            keep[count] = j
            count += 1
    return keep[:count]


@kernel
def gap_table(a, x, y, v0, samples, radii, beyond):
    """(near (K, n), counts (K,)): at each ROLLOUT_STEP k, the obstacles (indices in order, and their count)
    whose footprint gap to a rollout from (x, y) [m] starting at v0 [m/s] can be below `beyond` [m] then (on
    their lines or predicted paths, `samples`). The others can change neither a rollout's contact with a
    margin up to `beyond` nor its clearance capped at `beyond`: a plan's table, made once for its grid."""
    reach = np.empty((samples.shape[0], radii.shape[0]))
    for j in range(radii.shape[0]):
        reach[:, j] = radii[j] + a[A_ROBOT_RADIUS] + beyond
    # a rollout's speed stays between v0 and its goal
    return reachable(samples, x, y, reach, max(abs(v0), a[A_V_MAX]), ROLLOUT_STEP)


@kernel
def every_obstacle(samples, radii):
    """gap_table's (near, counts) that keeps every obstacle at every step."""
    near = np.empty((samples.shape[0], radii.shape[0]), dtype=np.int64)
    for k in range(samples.shape[0]):
        for j in range(radii.shape[0]):
            near[k, j] = j
    return near, np.full(samples.shape[0], radii.shape[0], dtype=np.int64)


@kernel
def rollout_among(a, x, y, yaw, v0, w0, v_goal, w_goal, samples, radii, near, counts, horizon, margin,
                  until_contact, goal_x=math.nan, goal_y=math.nan):
    """rollout against the obstacles of each step's row of (near, counts) (gap_table); with `until_contact`
    it stops at the first contact (for a caller that refuses any rollout with one), its clearance and end
    pose then those of that instant. Also returns its closest approach [m] to (goal_x, goal_y), if given
    (else inf: most callers do not read it, and it costs a square root a step)."""
    steps = max(1, int(horizon / ROLLOUT_STEP + 0.5))
    v = v0
    w = w0
    clearance = math.inf
    contact = math.inf
    robot_radius = a[A_ROBOT_RADIUS]
    toward_goal = not math.isnan(goal_x)
    closest = math.hypot(goal_x - x, goal_y - y) if toward_goal else math.inf
    for k in range(1, steps + 1):
        x, y, yaw, v, w = drive(a, x, y, yaw, v, w, v_goal, w_goal, ROLLOUT_STEP)
        if toward_goal:
            closest = min(closest, math.hypot(goal_x - x, goal_y - y))
        t = k * ROLLOUT_STEP
        for c in range(counts[k - 1]):
            j = near[k - 1, c]
            gap = math.sqrt(nearer_distance2(samples, k - 1, j, x, y)) - radii[j] - robot_radius
            clearance = min(clearance, gap)
            if gap < margin and contact == math.inf:
                contact = t
        if until_contact and contact < math.inf:
            break
    return clearance, contact, x, y, yaw, closest


@kernel
def rollout(a, x, y, yaw, v0, w0, v_goal, w_goal, samples, radii, horizon, margin):
    """(clearance, contact time, end x, end y, end yaw): drive towards (v_goal, w_goal) from (v0, w0) at the
    acceleration limits for `horizon` [s]; the smallest footprint clearance to the obstacles on their lines
    or their predicted paths (`samples`: prediction.hypotheses at ROLLOUT_STEP over the horizon; inf without
    obstacles) and when it first falls below `margin` [m] (inf never)."""
    near, counts = every_obstacle(samples, radii)
    return rollout_among(a, x, y, yaw, v0, w0, v_goal, w_goal, samples, radii, near, counts, horizon, margin,
                         False)[:5]


@kernel
def objective(heading_weight, clearance_weight, speed_weight, clearance_cap, heading_error, clearance, speed,
              v_max):
    """Fox et al.'s G(v, omega), each term in [0, 1]: the heading error [rad] at the rollout's end, its
    clearance [m] capped at clearance_cap, and its speed [m/s] over v_max."""
    heading = 1.0 - abs(wrap_angle(heading_error)) / math.pi
    return (heading_weight * heading
            + clearance_weight * min(max(clearance, 0.0), clearance_cap) / clearance_cap
            + speed_weight * speed / v_max)


@kernel
def dwa_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
             velocities, radii, distances):
    """One planning step of the dynamic window approach into `out` (Q_*)."""
    f_att_x, f_att_y, nearest, nearest_d, distance, moving_target = sampling_start(
        a, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions, radii, distances)
    v0 = m[R_LAST_V]
    w0 = m[R_LAST_OMEGA]
    cap = a[A_DWA_CLEARANCE_CAP]
    best_score = -math.inf
    best_contact = -1.0
    best_v = 0.0
    best_w = 0.0
    best_yaw = yaw
    v_top = top_speed(a, distance, moving_target)
    near = within_reach(a, x, y, v0, positions, velocities, radii, a[A_DWA_HORIZON], max(cap, a[A_SAFETY_MARGIN]))
    near_r = radii[near]
    samples = straight_hypotheses(positions[near], velocities[near], a[A_DWA_HORIZON], ROLLOUT_STEP)
    steps_near, steps_count = gap_table(a, x, y, v0, samples, near_r, max(cap, a[A_SAFETY_MARGIN]))
    for i in range(V_SAMPLES):
        for k in range(OMEGA_SAMPLES):
            v_goal, w_goal = candidate(a, v_top, i, k)
            clearance, contact, ex, ey, eyaw, _ = rollout_among(a, x, y, yaw, v0, w0, v_goal, w_goal, samples,
                                                                near_r, steps_near, steps_count, a[A_DWA_HORIZON],
                                                                a[A_SAFETY_MARGIN], False)
            score = objective(a[A_DWA_HEADING_WEIGHT], a[A_DWA_CLEARANCE_WEIGHT], a[A_DWA_SPEED_WEIGHT], cap,
                              math.atan2(target_y - ey, target_x - ex) - eyaw, clearance, v_goal, a[A_V_MAX])
            # admissible first (no contact within the horizon), then the latest contact, then the score
            if contact > best_contact or (contact == best_contact and score > best_score):
                best_contact = contact
                best_score = score
                best_v = v_goal
                best_w = w_goal
                best_yaw = eyaw
    sampling_finish(a, m, ring, out, stamp, x, y, distance, moving_target, nearest, nearest_d, f_att_x, f_att_y,
                    best_yaw, wrap_angle(best_yaw - yaw), best_v, best_w)
