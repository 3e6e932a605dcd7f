"""Walls the robot has seen and no longer sees: a short memory of a wall's chain of discs, in odom.

A scan shows the faces of walls that are in view, and nothing of those behind the robot or behind other
walls. A planner that forgets a wall as soon as it turns away from it drives back into a trap it has
just left (the inside of a U is out of view from its mouth). So each scan's chain discs are kept, in
odom, for `walls.memory` seconds after they were last seen, as a costmap's obstacle layer keeps its marks
(Nav2's ObstacleLayer, Marder-Eppstein et al. 2010): a disc the scan shows again replaces those it covers,
and a remembered disc is cleared when the beam towards its centre returns beyond it (the place is free
now), so a wall that was a person standing still, or a door that opened, does not stay. The scanner's
odometry drifts: what is remembered is only as good as odom over `walls.memory`.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_tracker.detection import DC_RADIUS, DC_WALL, DC_X, DC_Y

WALL_MEMORY_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("walls.memory", 20.0, "a wall disc out of view is kept this long after it was last seen (0: only"
              " the scan's own)", "s", 0.0, 600.0),
    ParamSpec("walls.max_discs", 256, "wall discs remembered at most (the least recently seen make room)", "", 1,
              10000),
)

SETTINGS_LAYOUT = Layout(("memory", "max_discs"))
WM_MEMORY = SETTINGS_LAYOUT["memory"]
WM_MAX_DISCS = SETTINGS_LAYOUT["max_discs"]
N_SETTINGS = len(SETTINGS_LAYOUT)

WALL_LAYOUT = Layout(("x", "y", "radius", "seen"))  # [m] in odom, [s] when a scan last showed it
WL_X = WALL_LAYOUT["x"]
WL_Y = WALL_LAYOUT["y"]
WL_RADIUS = WALL_LAYOUT["radius"]
WL_SEEN = WALL_LAYOUT["seen"]
N_WALL = len(WALL_LAYOUT)


def settings_vector(cfg: dict) -> np.ndarray:
    return SETTINGS_LAYOUT.pack({name: cfg[f"walls.{name}"] for name in SETTINGS_LAYOUT.names})


@kernel
def _drop(walls, j, n):
    """Remove row j of walls[:n] (the last row takes its place); returns the new count."""
    n -= 1
    walls[j, :] = walls[n, :]
    return n


@kernel
def _seen_through(walls, j, ranges, angle_min, angle_increment, sx, sy, yaw):
    """The beam from the scanner (sx, sy) towards remembered disc j returned beyond its centre (or not at
    all): the place is free now."""
    dx = walls[j, WL_X] - sx
    dy = walls[j, WL_Y] - sy
    dist = math.hypot(dx, dy)
    if dist <= walls[j, WL_RADIUS]:
        return False  # the scanner is inside it: nothing to say
    bearing = (math.atan2(dy, dx) - yaw - angle_min) % (2.0 * math.pi)
    i = round(bearing / angle_increment)
    if i >= ranges.shape[0]:
        return False  # outside the field of view
    return ranges[i] > dist  # +inf: no return within range at all


@kernel
def remember_walls(s, walls, n, t, discs, m, ranges, angle_min, angle_increment, sx, sy, yaw):
    """The memory walls[:n] after the scan at t [s] from the scanner at (sx, sy, yaw) [m, rad], whose discs
    are discs[:m] (their wall rows are taken): forgotten when too old or seen through, replaced where the
    scan shows the wall again, and the scan's wall discs added. Returns the new count."""
    j = 0
    while j < n:
        if (t - walls[j, WL_SEEN] > s[WM_MEMORY]
                or _seen_through(walls, j, ranges, angle_min, angle_increment, sx, sy, yaw)):
            n = _drop(walls, j, n)
        else:
            j += 1
    capacity = min(walls.shape[0], int(s[WM_MAX_DISCS]))
    for i in range(m):
        if discs[i, DC_WALL] == 0.0:
            continue
        j = 0
        while j < n:  # what this disc covers is this disc now (not its neighbours in this scan's chain)
            if walls[j, WL_SEEN] < t and math.hypot(walls[j, WL_X] - discs[i, DC_X],
                                                     walls[j, WL_Y] - discs[i, DC_Y]) < discs[i, DC_RADIUS]:
                n = _drop(walls, j, n)
            else:
                j += 1
        if n >= capacity:  # full: the least recently seen makes room
            oldest = 0
            for q in range(1, n):
                if walls[q, WL_SEEN] < walls[oldest, WL_SEEN]:
                    oldest = q
            n = _drop(walls, oldest, n)
        walls[n, WL_X] = discs[i, DC_X]
        walls[n, WL_Y] = discs[i, DC_Y]
        walls[n, WL_RADIUS] = discs[i, DC_RADIUS]
        walls[n, WL_SEEN] = t
        n += 1
    return n
