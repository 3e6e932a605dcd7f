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
from twbr_planner.prediction import MOVING, hypotheses, nearer_distance2

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
def predicted_reach(a, velocities, radii, j, t):
    """[m] how near obstacle j's predicted centre the robot's centre may come at t [s]: its radius, the
    footprint and yield_margin, grown by yield_uncertainty times the distance it walks by then."""
    return (radii[j] + (a[A_ROBOT_RADIUS] + a[A_YIELD_MARGIN])
            + a[A_YIELD_UNCERTAINTY] * math.hypot(velocities[j, 0], velocities[j, 1]) * t)


@kernel
def first_conflict(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, velocities, radii, horizon):
    """[s] when a rollout towards (v_goal, w_goal) from (v0, w0) first comes within yield_margin of a moving
    obstacle's predicted disc (on its line or its predicted path, `samples`: prediction.hypotheses at
    ROLLOUT_STEP over the horizon; grown by the uncertainty); `horizon` when it never does; and where the
    rollout is then. A finite `heading` [rad] steers to it instead of holding w_goal. Static obstacles are
    the field's and the safety filter's: they never start yielding (the candidates' `overlap` counts them)."""
    steps = max(1, int(horizon / ROLLOUT_STEP + 0.5))
    v = v0
    w = w0
    for k in range(1, steps + 1):
        x, y, yaw, v, w = rollout_step(a, x, y, yaw, v, w, v_goal, w_goal, heading)
        t = k * ROLLOUT_STEP
        for j in range(radii.shape[0]):
            vx = velocities[j, 0]
            vy = velocities[j, 1]
            if vx * vx + vy * vy < MOVING * MOVING:
                continue
            reach = predicted_reach(a, velocities, radii, j, t)
            if nearer_distance2(samples, k - 1, j, x, y) < reach * reach:
                return t - ROLLOUT_STEP, x, y  # the last instant known clear
    return horizon, x, y


@kernel
def overlap(a, x, y, yaw, v0, w0, v_goal, w_goal, heading, samples, velocities, radii, horizon):
    """[m s] how deep and how long a rollout (as first_conflict's, but against every obstacle) goes into the
    predicted discs, each step's depth weighted by exp(-t / yield_discount); and where the rollout ends."""
    steps = max(1, int(horizon / ROLLOUT_STEP + 0.5))
    v = v0
    w = w0
    total = 0.0
    for k in range(1, steps + 1):
        x, y, yaw, v, w = rollout_step(a, x, y, yaw, v, w, v_goal, w_goal, heading)
        t = k * ROLLOUT_STEP
        weight = math.exp(-t / a[A_YIELD_DISCOUNT])
        for j in range(radii.shape[0]):
            reach = predicted_reach(a, velocities, radii, j, t)
            d2 = nearer_distance2(samples, k - 1, j, x, y)
            if d2 < reach * reach:
                total += (reach - math.sqrt(d2)) * ROLLOUT_STEP * weight
    return total, x, y


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
    if first_conflict(a, x, y, yaw, v0, w0, v_nominal, omega_nominal, math.nan, samples, velocities, radii,
                      horizon)[0] >= horizon:
        return v_nominal, omega_nominal, False  # no moving obstacle in the way: the field's command stands
    # the rest is judged against every obstacle: backing away from a person must not back into a wall
    best, ex, ey = overlap(a, x, y, yaw, v0, w0, v_nominal, omega_nominal, math.nan, samples, velocities, radii,
                           horizon)
    best_v = v_nominal
    best_w = omega_nominal
    best_cost = math.hypot(target_x - ex, target_y - ey)
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
                depth, ex, ey = overlap(a, x, y, yaw, v0, w0, cv, cw, heading, samples, velocities, radii,
                                        horizon)
                # among equally safe ones, the one that ends nearest the target (the way on, not the way back)
                cost = math.hypot(target_x - ex, target_y - ey) + OMEGA_WEIGHT * (cw - omega_nominal) ** 2
                if depth < best - 1e-9 or (depth <= best + 1e-9 and cost < best_cost):
                    best = depth
                    best_v = cv
                    best_w = cw
                    best_cost = cost
    return best_v, best_w, best_v != v_nominal or best_w != omega_nominal
