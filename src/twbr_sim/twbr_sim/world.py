"""The world the robot navigates: a randomly turning target and circular obstacles at constant velocity.

The target moves at constant speed; its yaw rate is redrawn uniformly in +-max_yaw_rate every
turn_interval seconds from a seeded generator, and each segment is integrated exactly as an arc, so
the world at time t is the same whichever times it was sampled at. Obstacles move in straight lines.
Pure Python and numpy, no rclpy: the simulator node, world_node and batch runs share it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_sim.scenario import ObstacleSpec, Scenario


@dataclass(frozen=True)
class TargetState:
    x: float
    y: float
    heading: float
    speed: float
    yaw_rate: float

    @property
    def velocity(self) -> tuple[float, float]:
        return self.speed * math.cos(self.heading), self.speed * math.sin(self.heading)


@dataclass(frozen=True)
class Assessment:
    """Where the robot stands relative to the world at one instant."""

    collision: bool
    collision_obstacle_id: int  # -1 when none
    clearance: float  # footprint to the nearest obstacle surface [m]; inf without obstacles
    target_distance: float  # axle centre to target [m]
    target_reached: bool


def arc(x: float, y: float, heading: float, speed: float, yaw_rate: float, dt: float) -> tuple[float, float, float]:
    """Exact constant-speed, constant-yaw-rate motion over dt: (x, y, heading)."""
    new_heading = heading + yaw_rate * dt
    if abs(yaw_rate) < 1e-9:
        return x + speed * dt * math.cos(heading), y + speed * dt * math.sin(heading), new_heading
    radius = speed / yaw_rate
    return (
        x + radius * (math.sin(new_heading) - math.sin(heading)),
        y - radius * (math.cos(new_heading) - math.cos(heading)),
        new_heading,
    )


class World:
    def __init__(self, scenario: Scenario, robot_radius: float, seed: int) -> None:
        self.scenario = scenario
        self.robot_radius = robot_radius
        self._rng = np.random.default_rng(seed)
        tgt = scenario.target
        self._seg_t = 0.0
        if tgt is not None:
            self._seg_x, self._seg_y, self._seg_heading = tgt.x, tgt.y, tgt.heading
            self._seg_yaw_rate = self._draw_yaw_rate()
        self.time = 0.0
        self.collision_count = 0
        self._in_collision = False
        obs = scenario.obstacles
        self._ids = np.array([o.id for o in obs], dtype=int)
        self._p0 = np.array([[o.x, o.y] for o in obs], dtype=float).reshape(-1, 2)
        self._v = np.array([[o.vx, o.vy] for o in obs], dtype=float).reshape(-1, 2)
        self._radius = np.array([o.radius for o in obs], dtype=float)

    @property
    def capture_radius(self) -> float:
        """Distance at which the target counts as reached [m]; 0 without a target."""
        tgt = self.scenario.target
        return tgt.capture_radius if tgt is not None else 0.0

    def _draw_yaw_rate(self) -> float:
        w = self.scenario.target.max_yaw_rate
        return float(self._rng.uniform(-w, w)) if w > 0.0 else 0.0

    def advance_to(self, t: float) -> None:
        """Move the world forward to time t [s] (never backwards)."""
        if t < self.time:
            raise ValueError(f"world time cannot go back: {t} < {self.time}")
        tgt = self.scenario.target
        self.time = t
        if tgt is None:
            return
        interval = tgt.turn_interval
        while t >= self._seg_t + interval:
            self._seg_x, self._seg_y, self._seg_heading = arc(
                self._seg_x, self._seg_y, self._seg_heading, tgt.speed, self._seg_yaw_rate, interval
            )
            self._seg_t += interval
            self._seg_yaw_rate = self._draw_yaw_rate()

    def target(self) -> TargetState | None:
        tgt = self.scenario.target
        if tgt is None:
            return None
        x, y, heading = arc(
            self._seg_x, self._seg_y, self._seg_heading, tgt.speed, self._seg_yaw_rate, self.time - self._seg_t
        )
        return TargetState(x, y, math.remainder(heading, 2 * math.pi), tgt.speed, self._seg_yaw_rate)

    def obstacle_positions(self) -> np.ndarray:
        return self._p0 + self._v * self.time

    def obstacles(self) -> list[ObstacleSpec]:
        """The obstacles now: positions at the world's time, velocities and radii as specified."""
        pos = self.obstacle_positions()
        return [
            ObstacleSpec(int(i), float(p[0]), float(p[1]), float(v[0]), float(v[1]), float(r))
            for i, p, v, r in zip(self._ids, pos, self._v, self._radius, strict=True)
        ]

    def assess(self, robot_x: float, robot_y: float) -> Assessment:
        """Collision, clearance and target distance for the robot at (robot_x, robot_y); counts collisions."""
        tgt = self.target()
        target_distance = math.inf if tgt is None else math.hypot(tgt.x - robot_x, tgt.y - robot_y)
        clearance = math.inf
        hit_id = -1
        if len(self._radius):
            pos = self.obstacle_positions()
            gaps = np.hypot(pos[:, 0] - robot_x, pos[:, 1] - robot_y) - self._radius - self.robot_radius
            k = int(np.argmin(gaps))
            clearance = float(gaps[k])
            if clearance < 0.0:
                hit_id = int(self._ids[k])
        collision = hit_id >= 0
        if collision and not self._in_collision:
            self.collision_count += 1
        self._in_collision = collision
        return Assessment(
            collision=collision,
            collision_obstacle_id=hit_id,
            clearance=clearance,
            target_distance=target_distance,
            target_reached=tgt is not None and target_distance <= self.scenario.target.capture_radius,
        )
