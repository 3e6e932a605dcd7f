"""Was a collision avoidable? And why did a run fail? (the suite's failure classification)

A collision counts as unavoidable only if no admissible command sequence of the robot escapes the obstacle
from the moment it came into the detection range: the robot a unicycle from the state it had then (position,
heading, speed, yaw rate), within its speed, acceleration, braking, yaw-rate and yaw-acceleration limits,
the obstacle on its own path (its straight line at its constant velocity, or the path its motion kind
takes: twbr_sim.agents; an obstacle that reacts is taken on the path it would go with no robot in the
world, as the robot's manoeuvre is not the one it reacted to). It is computed, not assumed: 199 manoeuvres are
simulated to the horizon (steer to each of 24 headings at each of 5 speeds, with the yaw rate limit;
hold each of 11 yaw rates at each of 5 speeds; and brake to a stop while turning to each of 24 headings
then hold still), and the collision is avoidable when one of them keeps the footprint clear of the obstacle
throughout. A manoeuvre found proves avoidability; when none is found the collision is counted unavoidable,
so the count of avoidable collisions is a lower bound of the true one, tight to what these families reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.geometry import wrap_angle
from twbr_common.jit import kernel

HORIZON = 30.0  # [s] a manoeuvre must keep clear this long (or until the obstacle has passed)
DT = 0.05  # [s] integration step of the manoeuvres
HEADINGS = 24  # heading changes tried, evenly over the circle
SPEEDS = 5  # speeds tried, from -v_max to v_max
YAW_RATES = 11  # constant yaw rates tried, from -max to max
STEER_GAIN = 2.0  # [1/s] the yaw-rate command towards a heading (as the planners' K_s)


@dataclass(frozen=True)
class Limits:
    """What the robot can do: speed [m/s], acceleration and braking [m/s²], yaw rate [rad/s] and yaw
    acceleration [rad/s²]."""

    v_max: float
    acceleration: float
    braking: float
    yaw_rate: float
    yaw_acceleration: float


@kernel
def _clear_throughout(x, y, yaw, v, w, path, reach, limits, mode, target_heading, target_speed, target_rate, dt):
    """Simulate one manoeuvre; True when the centre stays `reach` or more from the obstacle's centre.

    mode 0: steer to target_heading at target_speed; 1: hold target_rate at target_speed; 2: brake to a
    stop while steering to target_heading, then stay.
    """
    v_max, acc, brake, rate_max, yaw_acc = limits[0], limits[1], limits[2], limits[3], limits[4]
    for k in range(1, path.shape[0]):
        if mode == 1:
            w_cmd = target_rate
        else:
            w_cmd = STEER_GAIN * wrap_angle(target_heading - yaw)
        w_cmd = min(max(w_cmd, -rate_max), rate_max)
        w = min(max(w_cmd, w - yaw_acc * dt), w + yaw_acc * dt)
        v_cmd = 0.0 if mode == 2 else target_speed
        v_cmd = min(max(v_cmd, -v_max), v_max)
        up = acc * dt
        down = brake * dt
        if v_cmd > v:
            v = min(v_cmd, v + (up if v >= 0.0 else down))
        else:
            v = max(v_cmd, v - (down if v > 0.0 else up))
        yaw += w * dt
        x += v * math.cos(yaw) * dt
        y += v * math.sin(yaw) * dt
        if (x - path[k, 0]) ** 2 + (y - path[k, 1]) ** 2 < reach * reach:
            return False
    return True


@kernel
def _escape_exists(x, y, yaw, v, w, path, reach, limits, dt):
    for k in range(HEADINGS):
        heading = yaw + 2.0 * math.pi * k / HEADINGS
        for i in range(SPEEDS):
            speed = limits[0] * (2.0 * i / (SPEEDS - 1) - 1.0)
            if _clear_throughout(x, y, yaw, v, w, path, reach, limits, 0, heading, speed, 0.0, dt):
                return True
        if _clear_throughout(x, y, yaw, v, w, path, reach, limits, 2, heading, 0.0, 0.0, dt):
            return True
    for k in range(YAW_RATES):
        rate = limits[3] * (2.0 * k / (YAW_RATES - 1) - 1.0)
        for i in range(SPEEDS):
            speed = limits[0] * (2.0 * i / (SPEEDS - 1) - 1.0)
            if _clear_throughout(x, y, yaw, v, w, path, reach, limits, 1, 0.0, speed, rate, dt):
                return True
    return False


def straight_path(obstacle: tuple[float, float, float, float], horizon: float = HORIZON) -> np.ndarray:
    """The positions every DT [s] over `horizon` of an obstacle at (x, y) [m] moving at (vx, vy) [m/s]."""
    k = np.arange(int(horizon / DT) + 1)[:, None] * DT
    return np.asarray(obstacle[:2], dtype=float) + k * np.asarray(obstacle[2:4], dtype=float)


def collision_avoidable(robot: tuple[float, float, float, float, float], obstacle: tuple[float, float, float, float]
                        | np.ndarray, radius: float, robot_radius: float, limits: Limits,
                        horizon: float = HORIZON) -> bool:
    """Whether an admissible manoeuvre keeps the footprint clear of the obstacle.

    robot: (x, y, yaw, speed, yaw rate) when the obstacle came into range; obstacle: (x, y, vx, vy) then
    (a straight path), or its path: positions every DT [s] from then on, (k, 2), over the horizon.
    """
    path = np.ascontiguousarray(obstacle, dtype=float)
    if path.ndim == 1:
        path = straight_path(tuple(path), horizon)
    if (robot[0] - path[0, 0]) ** 2 + (robot[1] - path[0, 1]) ** 2 < (radius + robot_radius) ** 2:
        return False  # already touching
    lim = np.array([limits.v_max, limits.acceleration, limits.braking, limits.yaw_rate, limits.yaw_acceleration])
    return bool(_escape_exists(*(float(v) for v in robot), path, radius + robot_radius, lim, DT))


OUTCOMES = ("success", "collision_avoidable", "collision_unavoidable", "fall", "trapped", "outrun", "late")


TRAPPED_SHARE = 0.25  # a run that missed its target with the planner stuck this share of the time was trapped


def classify(reached: bool, collided: bool, avoidable: bool | None, fallen: bool, stuck_at_end: bool,
             moving_target: bool, stuck_share: float = 0.0) -> str:
    """One run's outcome: success, or why it failed (a collision first, then a fall, then the way it missed
    the target: trapped in a local minimum (stuck at the end, or a quarter of the run), outrun by a moving
    target, or late on its way)."""
    if collided:
        return "collision_avoidable" if avoidable else "collision_unavoidable"
    if fallen:
        return "fall"
    if reached:
        return "success"
    if stuck_at_end or stuck_share >= TRAPPED_SHARE:
        return "trapped"
    return "outrun" if moving_target else "late"
