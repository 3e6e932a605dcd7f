"""The social force model's push (Helbing & Molnár 1995, "Social force model for pedestrian dynamics", Phys.
Rev. E 51(5)): one equation, shared by the world's walkers (twbr_sim.agents) and the planner's prediction of
them (twbr_planner.prediction), so that what the robot expects is what the world does."""

from __future__ import annotations

import math

from twbr_common.jit import kernel

# What the planner's prediction of walkers assumes; the world's walkers have their own anisotropy each (scenario
# files)
ANISOTROPY = 0.5  # Helbing's lambda: what is behind a walker pushes half as hard as what is ahead
REACH = 5.0  # discs farther than this many push ranges from a walker's surface (a push below e^-5 A): left out


@kernel
def helbing_push(strength, push_range, anisotropy, x, y, ux, uy, other_x, other_y, reach):
    """(ax, ay) [m/s^2]: the push on a walker at (x, y) [m] walking along the unit vector (ux, uy) from a disc
    at (other_x, other_y) whose surface is `reach` [m] from the centre of a walker touching it: A exp((reach -
    d) / B) along the line between them (A `strength` [m/s^2], B `push_range` [m]), weighted by lambda + (1 -
    lambda)(1 + cos phi) / 2 (lambda `anisotropy`: what is behind the walker counts less, eq. 4)."""
    dx = x - other_x
    dy = y - other_y
    d = max(math.hypot(dx, dy), 1e-6)
    magnitude = strength * math.exp((reach - d) / push_range)
    cos_phi = -(dx * ux + dy * uy) / d  # the other in front of it: 1
    weight = anisotropy + (1.0 - anisotropy) * 0.5 * (1.0 + cos_phi)
    return weight * magnitude * dx / d, weight * magnitude * dy / d
