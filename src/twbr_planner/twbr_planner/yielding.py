"""Yielding: the robust method's look-ahead over where the obstacles will be, which waits and backs out.

The field, the evasion and the safety filter act on the present (and the evasion on a straight-line
closest approach). Among people that is not enough: a person crossing behind the robot, a cart coming
down a passage the robot has entered, a flow it is about to join. This step looks `yield_horizon` seconds
ahead. Each obstacle's predicted position is on its line or on its predicted path (prediction.py: round
the static discs in its way), and its predicted disc grows
with the horizon by `yield_uncertainty` times the distance it walks (people turn, slow down and stop; the
set of places a walker can be widens with time, after the reachable-set view of Fiorini & Shiller's
velocity obstacles and the growing-covariance prediction of tracking filters). The robot's rollouts
reach their command at its acceleration limits (max_acceleration up, brake_deceleration down,
max_yaw_acceleration), so a stop takes as long as the robot takes to stop.

The field's command is kept while its rollout stays `yield_margin` clear of every moving obstacle's
predicted disc over the horizon (static ones are the field's and the safety filter's). Otherwise
candidate commands (forward, standing still, backing away, each turning or not) are rolled out against
every obstacle, static ones too (backing away from a person must not back into a wall), and the one that
overlaps the predicted discs least is taken: how deep it goes into each, summed over the horizon, an
overlap t seconds ahead weighted by exp(-t / yield_discount), since a nearer one is surer (its disc has
grown less) and leaves less time to change course; among equals, the one that ends nearest the target. So
the robot waits when going on meets a person, steps out of the lane of a walker faster than itself, and
backs out of a passage when standing in it would. Ranked by the latest first conflict instead, it ran on
ahead of faster walkers, in their lane (benchmarks/HISTORY.md, eighteenth session).
Compiled, like the rest of the method; each constant below is a resolution, not a tuning.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.geometry import wrap_angle
from twbr_common.jit import inline_kernel, kernel
from twbr_planner.apf import (
    A_MAX_YAW_RATE,
    A_ROBOT_RADIUS,
    A_V_MAX,
    A_YIELD_DISCOUNT,
    A_YIELD_HORIZON,
    A_YIELD_MARGIN,
    A_YIELD_UNCERTAINTY,
    R_LAST_OMEGA,
    R_LAST_V,
)
from twbr_planner.dwa import drive
from twbr_planner.prediction import MOVING, hypotheses, nearer_distance2, reachable

ROLLOUT_STEP = 0.25  # [s]
SPEEDS = 7  # candidate speeds, from -BACK_SHARE * v_max to v_max
BACK_SHARE = 0.5  # the fastest it backs out, as a share of v_max
YAW_RATES = 7  # candidate yaw rates, from -max_yaw_rate to max_yaw_rate
HEADINGS = 12  # candidate headings to steer to, round the circle (the escapes a sideways step needs)
STEER_GAIN = 2.0  # [1/s] the yaw-rate command towards a candidate heading (the field's K_s)
OMEGA_WEIGHT = 0.1  # [m s^2] among equally safe candidates: a yaw-rate change against their end's distance


@kernel
def rollout_step(a, x, y, yaw, v, w, v_goal, w_goal, heading):
    """(x, y, yaw, v, w) one ROLLOUT_STEP on towards (v_goal, w_goal) at the acceleration limits; a finite
    `heading` [rad] steers to it instead of holding w_goal."""
    return drive(a, x, y, yaw, v, w, v_goal, w_goal if math.isnan(heading) else steer_to(a, yaw, heading),
                 ROLLOUT_STEP)


@inline_kernel
def steer_to(a, yaw, heading):
    """[rad/s] the yaw rate a candidate steering to `heading` [rad] asks for, within max_yaw_rate."""
    return min(max(STEER_GAIN * wrap_angle(heading - yaw), -a[A_MAX_YAW_RATE]), a[A_MAX_YAW_RATE])


@kernel
def predicted_reach(a, radius, speed, t):
    """[m] how near the predicted centre of an obstacle of `radius` [m] walking at `speed` [m/s] the robot's
    centre may come at t [s]: its radius, the footprint and yield_margin, grown by yield_uncertainty times
    the distance it walks by then."""
    return radius + (a[A_ROBOT_RADIUS] + a[A_YIELD_MARGIN]) + a[A_YIELD_UNCERTAINTY] * speed * t


@kernel
def reach_table(a, x, y, speed_bound, samples, velocities, radii, horizon):
    """What a plan's rollouts read at each ROLLOUT_STEP k of the horizon, computed once: each obstacle's
    predicted reach [m] (K, n), and the obstacles a rollout from (x, y) no faster than speed_bound [m/s] can
    come within reach of then (their indices in order, (K, n), and their count, (K,)). The others can neither
    conflict with a rollout nor add to its overlap, so leaving them out changes no result, at a fraction of
    the cost among many obstacles."""
    steps = max(1, int(horizon / ROLLOUT_STEP + 0.5))
    n = radii.shape[0]
    reach = np.empty((steps, n))
    for j in range(n):
        speed = math.hypot(velocities[j, 0], velocities[j, 1])
        for k in range(1, steps + 1):
            reach[k - 1, j] = predicted_reach(a, radii[j], speed, k * ROLLOUT_STEP)
    near, counts = reachable(samples, x, y, reach, speed_bound, ROLLOUT_STEP)
    return reach, near, counts


@kernel
def conflict_along(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, velocities, reach, near, counts):
    """[s] when a rollout towards (v_goal, w_goal) from (v0, w0) first comes within yield_margin of a moving
    obstacle's predicted disc (on its line or its predicted path, `samples`: prediction.hypotheses at
    ROLLOUT_STEP over the horizon; grown by the uncertainty: reach_table); the horizon when it never does. A
    finite `heading` [rad] steers to it instead of holding w_goal. Static obstacles are the field's and the
    safety filter's: they never start yielding (the candidates' overlap counts them)."""
    steps = counts.shape[0]
    last = 0  # the rollout runs only up to the last step a moving obstacle can be met at
    for k in range(1, steps + 1):
        for c in range(counts[k - 1]):
            j = near[k - 1, c]
            if velocities[j, 0] * velocities[j, 0] + velocities[j, 1] * velocities[j, 1] >= MOVING * MOVING:
                last = k
    v = v0
    w = w0
    for k in range(1, last + 1):
        x, y, yaw, v, w = rollout_step(a, x, y, yaw, v, w, v_goal, w_goal, heading)
        for c in range(counts[k - 1]):
            j = near[k - 1, c]
            if velocities[j, 0] * velocities[j, 0] + velocities[j, 1] * velocities[j, 1] < MOVING * MOVING:
                continue
            r = reach[k - 1, j]
            if nearer_distance2(samples, k - 1, j, x, y) < r * r:
                return (k - 1) * ROLLOUT_STEP  # the last instant known clear
    return steps * ROLLOUT_STEP


@kernel
def first_conflict(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, velocities, radii, horizon):
    """[s] conflict_along of one rollout towards (v_goal, w_goal), its table made for it alone; `horizon` when
    it never conflicts."""
    reach, near, counts = reach_table(a, x, y, max(abs(v0), abs(v_goal)), samples, velocities, radii, horizon)
    t = conflict_along(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, velocities, reach, near, counts)
    return horizon if t >= counts.shape[0] * ROLLOUT_STEP else t


@kernel
def discounts(a, steps):
    """(K,) each ROLLOUT_STEP's weight in the overlap, exp(-t / yield_discount)."""
    weight = np.empty(steps)
    for k in range(1, steps + 1):
        weight[k - 1] = math.exp(-k * ROLLOUT_STEP / a[A_YIELD_DISCOUNT])
    return weight


@kernel
def overlap_along(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, reach, weight, near, counts, beyond):
    """[m s] how deep and how long a rollout (as conflict_along's, but against every obstacle) goes into the
    predicted discs, each step's depth weighted by its discount; and where the rollout ends. Once the depth
    passes `beyond` [m s] the rollout stops there (a candidate that cannot win any more: the depth only
    grows), its depth so far returned."""
    v = v0
    w = w0
    total = 0.0
    for k in range(1, weight.shape[0] + 1):
        x, y, yaw, v, w = rollout_step(a, x, y, yaw, v, w, v_goal, w_goal, heading)
        for c in range(counts[k - 1]):
            j = near[k - 1, c]
            r = reach[k - 1, j]
            d2 = nearer_distance2(samples, k - 1, j, x, y)
            if d2 < r * r:
                total += (r - math.sqrt(d2)) * ROLLOUT_STEP * weight[k - 1]
        if total > beyond:
            break
    return total, x, y


@kernel
def overlap(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, velocities, radii, horizon):
    """[m s] overlap_along of one rollout towards (v_goal, w_goal), its table made for it alone."""
    reach, near, counts = reach_table(a, x, y, max(abs(v0), abs(v_goal)), samples, velocities, radii, horizon)
    return overlap_along(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, reach,
                         discounts(a, counts.shape[0]), near, counts, math.inf)


@kernel
def in_reach(a, x, y, positions, velocities, radii, horizon, min_speed, margin, growth):
    """Whether an obstacle moving at `min_speed` [m/s] or faster can come within `margin` [m] of the robot's
    footprint within the horizon, its reach grown by `growth` times its speed (else nothing to yield to, or
    for the dynamic window to drive among)."""
    reach = a[A_ROBOT_RADIUS] + margin
    for j in range(radii.shape[0]):
        speed = math.hypot(velocities[j, 0], velocities[j, 1])
        if speed < min_speed:
            continue
        gap = math.hypot(positions[j, 0] - x, positions[j, 1] - y) - radii[j] - reach
        if gap < (a[A_V_MAX] + speed * (1.0 + growth)) * horizon:
            return True
    return False


@kernel
def yield_acts(a, x, y, positions, velocities, radii):
    """Whether the look-ahead runs: a moving obstacle can come within reach over yield_horizon (and it is on)."""
    horizon = a[A_YIELD_HORIZON]
    return horizon > 0.0 and in_reach(a, x, y, positions, velocities, radii, horizon, MOVING, a[A_YIELD_MARGIN],
                                      a[A_YIELD_UNCERTAINTY])


@kernel
def yield_command(a, m, x, y, yaw, v_nominal, omega_nominal, target_x, target_y, positions, velocities, radii,
                  paths):
    """(v, omega, yielding): the field's command if its look-ahead stays clear, else the candidate that
    overlaps the predicted discs least (the field's command, then the one ending nearest the target, among
    equals); yielding when it is not the field's."""
    if not yield_acts(a, x, y, positions, velocities, radii):
        return v_nominal, omega_nominal, False
    horizon = a[A_YIELD_HORIZON]
    v0 = m[R_LAST_V]
    w0 = m[R_LAST_OMEGA]
    samples = hypotheses(positions, velocities, paths, horizon, ROLLOUT_STEP)
    # every rollout's speed stays between v0 and its goal (the field's, or v_max forward, BACK_SHARE of it back)
    reach, near, counts = reach_table(a, x, y, max(abs(v0), abs(v_nominal), a[A_V_MAX]), samples, velocities,
                                      radii, horizon)
    steps = counts.shape[0]
    if conflict_along(a, x, y, yaw, v0, w0, v_nominal, omega_nominal, math.nan, samples, velocities, reach, near,
                      counts) >= steps * ROLLOUT_STEP:
        return v_nominal, omega_nominal, False  # no moving obstacle in the way: the field's command stands
    # the rest is judged against every obstacle: backing away from a person must not back into a wall
    weight = discounts(a, steps)
    best, ex, ey = overlap_along(a, x, y, yaw, v0, w0, v_nominal, omega_nominal, math.nan, samples, reach, weight,
                                 near, counts, math.inf)
    best_v = v_nominal
    best_w = omega_nominal
    best_cost = math.hypot(target_x - ex, target_y - ey)
    start_distance = math.hypot(target_x - x, target_y - y)
    # two families: hold a yaw rate, or steer to a heading (SPEEDS - 1 forward or backward speeds each)
    for family in range(2):
        for i in range(SPEEDS):
            cv = a[A_V_MAX] * (-BACK_SHARE + (1.0 + BACK_SHARE) * i / (SPEEDS - 1))
            for k in range(YAW_RATES if family == 0 else HEADINGS):
                heading = math.nan
                if family == 0:
                    cw = a[A_MAX_YAW_RATE] * (2.0 * k / (YAW_RATES - 1) - 1.0)
                else:
                    heading = yaw + 2.0 * math.pi * (k + 1) / (HEADINGS + 1)
                    cw = steer_to(a, yaw, heading)
                turn_cost = OMEGA_WEIGHT * (cw - omega_nominal) ** 2
                # once a clear one is found, one that cannot end nearer the target (its speed stays between
                # v0 and cv) cannot win: it is not rolled out
                travel = max(abs(v0), abs(cv)) * steps * ROLLOUT_STEP + 1e-6
                if best <= 1e-9 and start_distance - travel + turn_cost >= best_cost:
                    continue
                # one deeper than best + 1e-9 is refused below whatever its end: its rollout stops there
                depth, ex, ey = overlap_along(a, x, y, yaw, v0, w0, cv, cw, heading, samples, reach, weight,
                                              near, counts, best + 1e-9)
                # among equally safe ones, the one that ends nearest the target (the way on, not the way back)
                cost = math.hypot(target_x - ex, target_y - ey) + turn_cost
                if depth < best - 1e-9 or (depth <= best + 1e-9 and cost < best_cost):
                    best = depth
                    best_v = cv
                    best_w = cw
                    best_cost = cost
    return best_v, best_w, best_v != v_nominal or best_w != omega_nominal
