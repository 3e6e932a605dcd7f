"""The collision monitor: the last stage between any cmd_vel and the wheels, in the manner of Nav2's
collision_monitor (its "approach" behaviour on a circular footprint).

Whoever sent the command (our planner, a teleop, a foreign publisher), the forward speed reference is
limited to what stops the robot, braking at `deceleration`, `stop_margin` short of the first obstacle in
its way: the obstacles it knows (the planner's `obstacles`, moved along their velocity to the state's
instant) whose disc, grown by the robot's footprint, lies across the straight line the robot drives along
(forward or backward, as the command's sign says). The speed allowed at a free distance d is the v with
v * reaction_time + v^2 / (2 deceleration) = d - stop_margin: zero at the margin (the stop zone), less
than the command as the robot approaches (the slow-down zone). Turning is never limited: the footprint is a disc, and turning
in place moves it nowhere. It cannot stop an obstacle from driving into a robot that stands still.

One compiled kernel (`allowed_speed`) that the controller node and the batch engine call alike.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np

from twbr_common.jit import kernel
from twbr_common.params import ParamSpec, tunable
from twbr_common.timing import takes_effect_interpreted as takes_effect

MONITOR_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("collision_monitor.enabled", True, "limit every cmd_vel's forward speed to what stops the robot"
              " short of the obstacles in its way (the obstacles topic); false: commands pass as they are"),
    *tunable(
        ParamSpec("collision_monitor.footprint_radius", 0.3, "the robot's footprint, a disc about the axle centre",
                  "m", 0.0, 10.0, low_open=True),
        ParamSpec("collision_monitor.stop_margin", 0.05, "free distance at which the robot must stand: the stop"
                  " zone's depth", "m", 0.0, 10.0),
        ParamSpec("collision_monitor.deceleration", 0.25, "braking the allowed speed assumes, after reaction_time:"
                  " at a free distance d, v * reaction_time + v² / (2 deceleration) = d - stop_margin (keep it below"
                  " reference_rate.velocity, the steepest the velocity loop's reference falls)", "m/s²", 0.0, 100.0,
                  low_open=True),
        ParamSpec("collision_monitor.reaction_time", 0.3, "time the robot drives on at its speed before it brakes"
                  " (a balancing robot leans back first)", "s", 0.0, 10.0),
        ParamSpec("collision_monitor.release_acceleration", 0.1, "once the monitor has lowered the speed, the"
                  " controller's v_ref returns to the command no faster than this (the limit lets go in one step"
                  " when the obstacle leaves the way: the robot would lean into it); 0: under"
                  " reference_rate.velocity only", "m/s²", 0.0, 100.0),
    ),
    ParamSpec("collision_monitor.obstacle_timeout", 1.0, "an obstacle list older than this (against the state's"
              " stamp) is not used: the monitor then passes commands as they are", "s", 0.01, 60.0),
)


@kernel
def allowed_speed(v_cmd, x, y, yaw, positions, velocities, radii, age, footprint, stop_margin, deceleration,
                  reaction_time):
    """The forward speed reference [m/s] the robot at (x, y, yaw) may follow instead of v_cmd: v_cmd, or
    less in magnitude (same sign) where an obstacle lies in the way. positions, velocities: (n, 2) at a
    list's stamp, moved here by `age` [s]; radii: (n,)."""
    if v_cmd == 0.0:
        return 0.0
    direction = 1.0 if v_cmd > 0.0 else -1.0
    c = math.cos(yaw)
    s = math.sin(yaw)
    limit = abs(v_cmd)
    for i in range(radii.shape[0]):
        dx = positions[i, 0] + velocities[i, 0] * age - x
        dy = positions[i, 1] + velocities[i, 1] * age - y
        ahead = direction * (c * dx + s * dy)  # along the way the command drives
        lateral = -s * dx + c * dy
        reach = footprint + radii[i]
        if ahead <= 0.0 or abs(lateral) >= reach:
            continue  # behind, or beside the way
        free = ahead - math.sqrt(reach * reach - lateral * lateral) - stop_margin
        # v * reaction_time + v^2 / (2 deceleration) = free: the robot follows a lower reference only after its
        # balance has leaned it back (the cascade's lag), then brakes
        speed = (deceleration * (math.sqrt(reaction_time * reaction_time + 2.0 * free / deceleration) - reaction_time)
                 if free > 0.0 else 0.0)
        if speed < limit:
            limit = speed
    return direction * limit


class CollisionMonitor:
    """The node's monitor: the obstacle list in effect, and the command limited at each state.

    A list applies from the first state stamped after it (timing.takes_effect), as a command does. The
    world's list comes beside the state of its instant and the tracker's a few ms after it: which of the
    two reaches the node first is a race, and the list in use at that state would be a coin toss (a
    suite/trap_small run on the LiDAR left the batch engine's path by it). Until the next state the new
    list waits, however early it came."""

    PENDING = 8  # lists kept until their state comes: more than ever arrive between two states

    def __init__(self, settings: Mapping[str, Any]) -> None:
        self.retune(settings)
        self.reset()

    def retune(self, settings: Mapping[str, Any]) -> None:
        self.enabled = bool(settings["collision_monitor.enabled"])
        self.footprint = float(settings["collision_monitor.footprint_radius"])
        self.stop_margin = float(settings["collision_monitor.stop_margin"])
        self.deceleration = float(settings["collision_monitor.deceleration"])
        self.reaction_time = float(settings["collision_monitor.reaction_time"])
        self.timeout = float(settings["collision_monitor.obstacle_timeout"])

    def reset(self) -> None:
        self.stamp: float | None = None
        self.positions = np.empty((0, 2))
        self.velocities = np.empty((0, 2))
        self.radii = np.empty(0)
        self.interventions = 0
        self._pending: deque[tuple[float, np.ndarray]] = deque(maxlen=self.PENDING)

    def obstacles(self, stamp: float, rows: np.ndarray) -> None:
        """An admitted obstacle list (rows of id, x, y, vx, vy, radius, stamped in order): in effect from the
        first state stamped after `stamp`."""
        self._pending.append((stamp, rows))

    def _take(self, stamp: float) -> None:
        """The newest list stamped before the state stamped `stamp` comes into effect."""
        while self._pending and takes_effect(self._pending[0][0], stamp):
            self.stamp, rows = self._pending.popleft()
            self.positions = np.ascontiguousarray(rows[:, 1:3])
            self.velocities = np.ascontiguousarray(rows[:, 3:5])
            self.radii = np.ascontiguousarray(rows[:, 5])

    def watching(self, stamp: float) -> bool:
        """It has a current obstacle list for the state stamped `stamp`."""
        self._take(stamp)
        return self.enabled and self.stamp is not None and stamp - self.stamp <= self.timeout

    def limit(self, stamp: float, v_cmd: float, x: float, y: float, yaw: float) -> tuple[float, bool]:
        """(the speed reference to follow, whether it was lowered) for the state stamped `stamp`."""
        if not self.watching(stamp):
            return v_cmd, False
        v = allowed_speed(float(v_cmd), float(x), float(y), float(yaw), self.positions, self.velocities, self.radii,
                          max(0.0, stamp - self.stamp), self.footprint, self.stop_margin, self.deceleration,
                          self.reaction_time)
        limited = v != v_cmd
        self.interventions += limited
        return v, limited
