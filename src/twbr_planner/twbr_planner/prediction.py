"""Robust addition 8, prediction: where each moving obstacle will be, bending round the static discs in its
way as people do, not only along its straight line.

The window's and the yielding's rollouts judge a command against where the moving obstacles will be. A
straight line is what a cart does; a person walking through clutter steps round the post ahead of them
(clutter with movers: most of the robust method's collisions there were with walkers whose paths bent round
a post the robot was passing, benchmarks/HISTORY.md). Each moving obstacle is predicted here with the
social force model (Helbing & Molnár 1995; the world's walkers' own push, twbr_common.social_force):
it wants to keep its present velocity (the planner knows neither its goal nor its route), relaxes towards it
in `prediction_relaxation_time`, and every static disc pushes it away by
A exp((r_ij - d_ij) / B) along the line between them (A `prediction_strength`, B `prediction_range`),
weighted by lambda + (1 - lambda)(1 + cos phi) / 2 with lambda = ANISOTROPY (a disc behind it counts less),
its speed held below SPEED_CAP times its present speed.

A planner cannot tell a person from a cart, which goes on along its line whatever is beside it: in a passage
the walls' pushes, whose sideways parts cancel, predict a cart coming through it slowed to a crawl, and a
robot that trusts that enters the passage (suite/narrow_passage, seeds 1-60: 6 avoidable collisions with the
bent path alone, 2 with the straight line). So a rollout meets an obstacle where either comes near: its
straight line or its bent path (`hypotheses`). Other moving obstacles and the robot do not push in
the prediction: how people give way to each other and to a robot is the part no planner can count on, and
yielding's growing discs (yield_uncertainty) stand for it. prediction_strength 0 gives the straight lines
(the dynamic window baseline's constant-velocity prediction, `method: dwa`).

The paths are sampled every PREDICTION_STEP seconds and read between samples by linear interpolation;
compiled, shared with the batch engine like the rest of the method.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.social_force import ANISOTROPY, REACH, helbing_push

PREDICTION_STEP = 0.2  # [s] the paths' sampling and integration step
SPEED_CAP = 1.3  # a predicted walker stays below this times its present speed (Helbing's v_max = 1.3 v0)
MOVING = 1e-3  # [m/s] an obstacle slower than this is static


@kernel
def predict_paths(positions, velocities, radii, horizon, strength, push_range, relaxation_time):
    """(n, K + 1, 2) each obstacle's predicted position [m] at k PREDICTION_STEP, k = 0..K, over `horizon` [s]:
    static ones where they are, moving ones pushed round the static discs (strength [m/s^2] 0: on their
    straight lines)."""
    n = radii.shape[0]
    steps = max(1, int(horizon / PREDICTION_STEP + 1.0 - 1e-9))  # at least up to the horizon
    dt = PREDICTION_STEP
    paths = np.empty((n, steps + 1, 2))
    static = np.empty(n, dtype=np.int64)
    n_static = 0
    for j in range(n):
        if math.hypot(velocities[j, 0], velocities[j, 1]) < MOVING:
            static[n_static] = j
            n_static += 1
    near = np.empty(n, dtype=np.int64)
    for j in range(n):
        x = positions[j, 0]
        y = positions[j, 1]
        want_x = velocities[j, 0]
        want_y = velocities[j, 1]
        speed0 = math.hypot(want_x, want_y)
        paths[j, 0, 0] = x
        paths[j, 0, 1] = y
        # the static discs it can come near over the horizon (no push from the others); none where it
        # overlaps one already: that is not a body keeping its distance (a LiDAR sliver of a disc seen
        # through a gap, a track merging with a wall), and the push, exponential in the overlap, would
        # fling it off the disc across the robot's way
        n_near = 0
        if strength > 0.0 and speed0 >= MOVING:
            travel = SPEED_CAP * speed0 * horizon + REACH * push_range
            for s in range(n_static):
                o = static[s]
                gap = math.hypot(positions[o, 0] - x, positions[o, 1] - y) - radii[o] - radii[j]
                if gap < 0.0:
                    n_near = 0
                    break
                if gap <= travel:
                    near[n_near] = o
                    n_near += 1
        if n_near == 0:
            for k in range(1, steps + 1):
                paths[j, k, 0] = x + want_x * k * dt
                paths[j, k, 1] = y + want_y * k * dt
            continue
        vx = want_x
        vy = want_y
        cap = SPEED_CAP * speed0
        for k in range(1, steps + 1):
            ax = (want_x - vx) / relaxation_time
            ay = (want_y - vy) / relaxation_time
            speed = max(math.hypot(vx, vy), 1e-9)
            ux = vx / speed
            uy = vy / speed
            for s in range(n_near):
                o = near[s]
                dx = x - positions[o, 0]
                dy = y - positions[o, 1]
                reach = radii[o] + radii[j]
                far = reach + REACH * push_range
                d2 = dx * dx + dy * dy
                if d2 > far * far:
                    continue
                px, py = helbing_push(strength, push_range, ANISOTROPY, x, y, ux, uy, positions[o, 0],
                                      positions[o, 1], reach)
                ax += px
                ay += py
            vx += ax * dt
            vy += ay * dt
            speed = math.hypot(vx, vy)
            if speed > cap:
                vx *= cap / speed
                vy *= cap / speed
            x += vx * dt
            y += vy * dt
            paths[j, k, 0] = x
            paths[j, k, 1] = y
    return paths


@kernel
def straight_hypotheses(positions, velocities, horizon, step):
    """`hypotheses` of obstacles on their straight lines alone (Fox et al.'s constant velocity, the `dwa`
    method's): both of an obstacle's positions on its line; `hypotheses` then puts the bent paths beside."""
    count = max(1, int(horizon / step + 0.5))
    n = positions.shape[0]
    out = np.empty((count, n, 4))
    for k in range(count):
        t = (k + 1) * step
        for j in range(n):
            out[k, j, 0] = out[k, j, 2] = positions[j, 0] + velocities[j, 0] * t
            out[k, j, 1] = out[k, j, 3] = positions[j, 1] + velocities[j, 1] * t
    return out


@kernel
def hypotheses(positions, velocities, paths, horizon, step):
    """(K, n, 4) [m]: each obstacle at k `step` [s], k = 1..K (K = horizon / step, rounded, at least 1), on its
    straight line (x, y: a cart's) and on its bent path (x, y: a person's). A rollout meets the nearer of the
    two; they are the same for every rollout of a plan, so they are computed once per plan."""
    out = straight_hypotheses(positions, velocities, horizon, step)
    for k in range(out.shape[0]):
        t = (k + 1) * step
        for j in range(positions.shape[0]):
            out[k, j, 2], out[k, j, 3] = predicted_position(paths, j, t)
    return out


@kernel
def nearer_distance2(samples, k, j, x, y):
    """[m^2] the squared distance from (x, y) to the nearer of obstacle j's two positions in `samples` row k
    (hypotheses)."""
    dx = x - samples[k, j, 0]
    dy = y - samples[k, j, 1]
    ex = x - samples[k, j, 2]
    ey = y - samples[k, j, 3]
    return min(dx * dx + dy * dy, ex * ex + ey * ey)


@kernel
def reachable(samples, x, y, reach, speed_bound, step):
    """(near (K, n), counts (K,)): at each k `step` [s] of `samples` (hypotheses), the obstacles (indices in
    order, and their count) whose nearer position can be within reach[k - 1, j] [m] of a robot that left
    (x, y) [m] no faster than speed_bound [m/s]. Only these can meet a rollout of the plan at that step: the
    window's and the yielding's rollouts read this table instead of trying every obstacle."""
    steps, n = reach.shape
    near = np.empty((steps, n), dtype=np.int64)
    counts = np.zeros(steps, dtype=np.int64)
    for k in range(1, steps + 1):
        travel = speed_bound * k * step + 1e-6  # the farthest the robot gets from (x, y) by then
        count = 0
        for j in range(n):
            r = reach[k - 1, j] + travel
            if nearer_distance2(samples, k - 1, j, x, y) < r * r:
                near[k - 1, count] = j
                count += 1
        counts[k - 1] = count
    return near, counts


@kernel
def predicted_position(paths, j, t):
    """(x, y) [m]: obstacle j's predicted position at t [s], between the samples on a straight line, beyond
    the last one along the last sample's step."""
    f = t / PREDICTION_STEP
    k = min(int(f), paths.shape[1] - 2)  # predict_paths samples at least twice
    u = f - k
    return (paths[j, k, 0] + u * (paths[j, k + 1, 0] - paths[j, k, 0]),
            paths[j, k, 1] + u * (paths[j, k + 1, 1] - paths[j, k, 1]))
