"""A unicycle that does what a planner says, for the planner's tests (no controller, no balance)."""

import math

import numpy as np

from twbr_planner.apf import Mode, Obstacles
from twbr_planner.planner import ApfPlanner, Target
from twbr_planner.planner_params import resolve

PERIOD = 0.05  # [s] the node's default planning period


def drive(method, target, obstacles=(), seconds=60.0, start=(0.0, 0.0, 0.0), **settings):
    """A unicycle that does what the planner says; obstacles (id, x, y, r, vx, vy) move at their velocity.
    Returns the poses, the outputs and the smallest footprint clearance."""
    planner = ApfPlanner(resolve({"method": method, **settings}))
    x, y, yaw = start
    v = 0.0
    poses, outputs = [], []
    clearance = math.inf
    for k in range(int(seconds / PERIOD)):
        t = k * PERIOD
        now = [(i, ox + vx * t, oy + vy * t, r, vx, vy) for i, ox, oy, r, vx, vy in obstacles]
        out = planner.step(t, x, y, yaw, v, Target(*target, 0.0, 0.0), Obstacles.of(now) if now else Obstacles.empty())
        outputs.append(out)
        v = out.velocity_cmd
        yaw += out.yaw_rate_cmd * PERIOD
        x += v * math.cos(yaw) * PERIOD
        y += v * math.sin(yaw) * PERIOD
        poses.append((x, y, yaw))
        for _, ox, oy, r, _, _ in now:
            clearance = min(clearance, math.hypot(x - ox, y - oy) - r - 0.3)
        if out.mode is Mode.ARRIVED:
            break
    return np.array(poses), outputs, clearance
