"""A navigation function for the robust planner's escape: a potential with no local minimum but the target.

A potential field's sum of attraction and repulsion has local minima (a trap's bottom, a row of discs
whose gaps are too narrow for the robot); the robust method leaves them along the gradient of a
discrete navigation function instead (Barraquand & Latombe 1991; Latombe, Robot Motion Planning, ch. 7:
a wavefront potential on a grid). Its cost-to-go to the target, searched by A* over
the free cells of a grid around the robot and the target, decreases along every path to the target and
has no other minimum, so following it reaches the target whenever the static obstacles leave a way
there; moving obstacles are left to the dynamic repulsion and the safety filter.

Cells closer than `inflate` to an obstacle's surface are blocked (the robot's footprint and a margin),
except on the way out of that band (a robot may be in it) and within `inflate` of the target;
free cells cost more the closer they are to one (within COMFORT), so the way keeps to the middle of a gap.
It is computed only while the robot escapes, each planning step, so it follows a moving target.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from twbr_common.jit import kernel

RESOLUTION = 0.1  # [m] the grid's cell, finest
MAX_CELLS = 40000  # the grid coarsens beyond this many cells
PAD = 3.0  # [m] around the robot and the target, at least
GROW_ROUNDS = 8  # times the grid grows to hold the obstacles reaching into it
COMFORT = 0.4  # [m] beyond the footprint, a cell closer than this to an obstacle costs more
CLEARANCE_COST = 2.0  # the extra cost per metre of a cell touching the blocked ones
LOOK = 0.8  # [m] the direction aims at least this far along the way
SIGHT_MARGIN = COMFORT  # [m] a straight line to the way passes the discs by inflate and this much


SQRT2 = math.sqrt(2.0)


@kernel
def _octile(i, k, goal_i, goal_k, resolution):
    """[m] the shortest 8-connected grid distance between two cells, ignoring obstacles."""
    di = abs(i - goal_i)
    dk = abs(k - goal_k)
    return resolution * (max(di, dk) + (SQRT2 - 1.0) * min(di, dk))


@kernel
def _cell(value, origin, resolution, count):
    """The index of the cell whose centre is nearest `value`, within the grid."""
    return min(max(int((value - origin) / resolution + 0.5), 0), count - 1)


@kernel
def navigation_direction(x, y, target_x, target_y, positions, radii, moving, inflate):
    """(ux, uy, found): the unit direction from (x, y) down the navigation function towards the target,
    over the obstacles not flagged `moving`; found is False when no way leads there (then (0, 0))."""
    # the grid: the robot and the target with PAD round them, grown to hold (with room to pass round) every
    # obstacle that reaches into it, so a wall that reaches out of the box is gone round, not through
    far = inflate + COMFORT
    x0 = min(x, target_x) - PAD
    y0 = min(y, target_y) - PAD
    x1 = max(x, target_x) + PAD
    y1 = max(y, target_y) + PAD
    for _ in range(GROW_ROUNDS):
        grown = False
        for j in range(radii.shape[0]):
            if moving[j]:
                continue
            room = radii[j] + far + 2.0 * RESOLUTION
            px = positions[j, 0]
            py = positions[j, 1]
            if px + room < x0 or px - room > x1 or py + room < y0 or py - room > y1:
                continue
            if px - room < x0 or px + room > x1 or py - room < y0 or py + room > y1:
                x0 = min(x0, px - room)
                x1 = max(x1, px + room)
                y0 = min(y0, py - room)
                y1 = max(y1, py + room)
                grown = True
        if not grown:
            break
    width = x1 - x0
    height = y1 - y0
    resolution = max(RESOLUTION, math.sqrt(width * height / MAX_CELLS))
    nx = int(width / resolution) + 1
    ny = int(height / resolution) + 1
    # clearance of each cell centre to the nearest obstacle's surface, up to inflate + COMFORT
    clearance = np.full(nx * ny, far)
    for j in range(radii.shape[0]):
        if moving[j]:
            continue
        reach = radii[j] + far
        i_lo = max(int((positions[j, 0] - reach - x0) / resolution), 0)
        i_hi = min(int((positions[j, 0] + reach - x0) / resolution) + 1, nx - 1)
        k_lo = max(int((positions[j, 1] - reach - y0) / resolution), 0)
        k_hi = min(int((positions[j, 1] + reach - y0) / resolution) + 1, ny - 1)
        for i in range(i_lo, i_hi + 1):
            cx = x0 + i * resolution - positions[j, 0]
            for k in range(k_lo, k_hi + 1):
                cy = y0 + k * resolution - positions[j, 1]
                c = math.sqrt(cx * cx + cy * cy) - radii[j]
                if c < clearance[i * ny + k]:
                    clearance[i * ny + k] = c
    start_i = _cell(x, x0, resolution, nx)
    start_k = _cell(y, y0, resolution, ny)
    goal_i = _cell(target_x, x0, resolution, nx)
    goal_k = _cell(target_y, y0, resolution, ny)
    start = start_i * ny + start_k
    goal = goal_i * ny + goal_k
    # A* from the robot (its own cell, and the target's, may touch an obstacle) with the octile distance,
    # which never overestimates the cost-to-go, so the way found is the navigation function's descent
    cost = np.full(nx * ny, math.inf)
    parent = np.full(nx * ny, -1, dtype=np.int64)
    cost[start] = 0.0
    heap = [(0.0, start)]
    while len(heap) > 0:
        f, cell = heapq.heappop(heap)
        if cell == goal:
            break
        ci = cell // ny
        ck = cell - ci * ny
        if f > cost[cell] + _octile(ci, ck, goal_i, goal_k, resolution) + 1e-9:
            continue  # a stale entry
        for di in range(-1, 2):
            for dk in range(-1, 2):
                if di == 0 and dk == 0:
                    continue
                i = ci + di
                k = ck + dk
                if i < 0 or i >= nx or k < 0 or k >= ny:
                    continue
                nb = i * ny + k
                if clearance[nb] < inflate and clearance[nb] <= clearance[cell] and (
                        _octile(i, k, goal_i, goal_k, resolution) > inflate):
                    continue  # into the blocked band only outwards (from where the robot is) or at the target
                step = resolution * (SQRT2 if di != 0 and dk != 0 else 1.0)
                near = max(0.0, 1.0 - (clearance[nb] - inflate) / COMFORT)
                candidate = cost[cell] + step * (1.0 + CLEARANCE_COST * near)
                if candidate < cost[nb]:
                    cost[nb] = candidate
                    parent[nb] = cell
                    heapq.heappush(heap, (candidate + _octile(i, k, goal_i, goal_k, resolution), nb))
    if cost[goal] == math.inf:
        return 0.0, 0.0, False
    # The way's farthest point the robot sees in a straight line (the grid's 8 directions straightened, as
    # Theta* would), at least its cell LOOK along; seen means every disc passed by `inflate` + SIGHT_MARGIN.
    # A robot closer than that to a disc takes the cell LOOK along, which leads out of the band.
    sight = inflate + SIGHT_MARGIN
    smooth = _surface_clearance(x, y, positions, radii, moving) >= sight
    cell = goal
    steps = 0
    while cell != start:
        cell = parent[cell]
        steps += 1
    look = max(steps - int(LOOK / resolution), 0)  # from the target's end
    aim = goal
    cell = goal
    for index in range(look + 1):
        px = x0 + (cell // ny) * resolution
        py = y0 + (cell - (cell // ny) * ny) * resolution
        if index == look or (smooth and _segment_clear(x, y, px, py, positions, radii, moving, sight)):
            aim = cell
            break
        cell = parent[cell]
    if aim == goal:
        ax = target_x - x
        ay = target_y - y
    else:
        ax = x0 + (aim // ny) * resolution - x
        ay = y0 + (aim - (aim // ny) * ny) * resolution - y
    norm = math.hypot(ax, ay)
    if norm < 1e-9:
        return 0.0, 0.0, True
    return ax / norm, ay / norm, True


@kernel
def _surface_clearance(x, y, positions, radii, moving):
    """[m] from (x, y) to the nearest static disc's surface."""
    nearest = math.inf
    for j in range(radii.shape[0]):
        if not moving[j]:
            nearest = min(nearest, math.hypot(positions[j, 0] - x, positions[j, 1] - y) - radii[j])
    return nearest


@kernel
def _segment_clear(x, y, px, py, positions, radii, moving, inflate):
    """Whether the segment from (x, y) to (px, py) passes every static disc by at least `inflate`."""
    dx = px - x
    dy = py - y
    length2 = dx * dx + dy * dy
    for j in range(radii.shape[0]):
        if moving[j]:
            continue
        ox = positions[j, 0] - x
        oy = positions[j, 1] - y
        u = min(max((ox * dx + oy * dy) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
        if math.hypot(ox - u * dx, oy - u * dy) < radii[j] + inflate:
            return False
    return True
