"""The world the robot navigates: a randomly turning target and circular obstacles that move.

The target moves at constant speed; its yaw rate is redrawn uniformly in +-max_yaw_rate every
turn_interval seconds from a seeded generator, and each segment is integrated exactly as an arc, so
the target at time t is the same whichever times it was sampled at. Obstacles move by their kind
(twbr_sim.agents: straight lines, waypoint routes, wandering, with or without reacting to the robot and
each other); those that react take the robot's pose the world was last given.
No rclpy: the simulator node, world_node and the headless runs use `World`; it and the batch engine
call the same compiled kernels (the target's segments, the agents' steps, the assessment).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from twbr_common.geometry import wrap_angle
from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_sim.agents import N_AGENT_STATE, agent_arrays, agents_advance, agents_at, agents_begin, stepped
from twbr_sim.scenario import ObstacleSpec, Scenario, vary

# The target's current segment: where and when it started, its heading then, its yaw rate, and the index
# of the next yaw-rate draw.
SEGMENT_LAYOUT = Layout(("x", "y", "heading", "t", "yaw_rate", "next_draw"))
SEG_X = SEGMENT_LAYOUT["x"]
SEG_Y = SEGMENT_LAYOUT["y"]
SEG_HEADING = SEGMENT_LAYOUT["heading"]
SEG_T = SEGMENT_LAYOUT["t"]
SEG_YAW_RATE = SEGMENT_LAYOUT["yaw_rate"]
SEG_NEXT_DRAW = SEGMENT_LAYOUT["next_draw"]
N_SEGMENT = len(SEGMENT_LAYOUT)
# The world's tally of collisions: how many began, and whether the robot is in one now.
TALLY_LAYOUT = Layout(("collisions", "in_collision"))
W_COLLISIONS = TALLY_LAYOUT["collisions"]
W_IN_COLLISION = TALLY_LAYOUT["in_collision"]
N_TALLY = len(TALLY_LAYOUT)


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


@kernel
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


@kernel
def advance_segments(seg, yaw_rate_draws, t, speed, interval):
    """Move the target's segment on to the one holding time t; False when the draws ran out first."""
    while t >= seg[SEG_T] + interval:
        k = int(seg[SEG_NEXT_DRAW])
        if k >= yaw_rate_draws.shape[0]:
            return False
        seg[SEG_X], seg[SEG_Y], seg[SEG_HEADING] = arc(
            seg[SEG_X], seg[SEG_Y], seg[SEG_HEADING], speed, seg[SEG_YAW_RATE], interval
        )
        seg[SEG_T] += interval
        seg[SEG_YAW_RATE] = yaw_rate_draws[k]
        seg[SEG_NEXT_DRAW] = k + 1
    return True


@kernel
def target_at(seg, speed, t):
    """(x, y, heading, vx, vy) of the target at time t within its segment."""
    x, y, heading = arc(seg[SEG_X], seg[SEG_Y], seg[SEG_HEADING], speed, seg[SEG_YAW_RATE], t - seg[SEG_T])
    heading = wrap_angle(heading)
    return x, y, heading, speed * math.cos(heading), speed * math.sin(heading)


@kernel
def assess_obstacles(positions, radii, robot_radius, robot_x, robot_y, tally):
    """(clearance, index of the obstacle hit or -1): footprint to the nearest surface [m], inf without
    obstacles; a collision that begins now is counted in `tally`."""
    clearance = math.inf
    nearest = -1
    for j in range(radii.shape[0]):
        gap = math.hypot(positions[j, 0] - robot_x, positions[j, 1] - robot_y) - radii[j] - robot_radius
        if gap < clearance or nearest < 0:
            clearance = gap
            nearest = j
    hit = nearest if nearest >= 0 and clearance < 0.0 else -1
    if hit >= 0 and tally[W_IN_COLLISION] == 0.0:
        tally[W_COLLISIONS] += 1.0
    tally[W_IN_COLLISION] = 1.0 if hit >= 0 else 0.0
    return clearance, hit


def yaw_rate_draws(rng: np.random.Generator, max_yaw_rate: float, count: int) -> np.ndarray:
    """The next `count` yaw rates of the target, uniform in +-max_yaw_rate (no draw when it is 0)."""
    if max_yaw_rate > 0.0:
        return rng.uniform(-max_yaw_rate, max_yaw_rate, count)
    return np.zeros(count)


def draws_needed(duration: float, turn_interval: float) -> int:
    """Yaw-rate draws a run of `duration` [s] uses: the first segment's and one per turn."""
    return math.floor(duration / turn_interval) + 2


class World:
    def __init__(self, scenario: Scenario, robot_radius: float, seed: int) -> None:
        """The world of `seed`: its layout (scenario.vary) and its target's turns."""
        scenario = vary(scenario, seed)
        self.scenario = scenario
        self.robot_radius = robot_radius
        self._rng = np.random.default_rng(seed)
        self.segment = np.zeros(N_SEGMENT)
        self._draws = np.zeros(0)
        tgt = scenario.target
        if tgt is not None:
            self._draws = yaw_rate_draws(self._rng, tgt.max_yaw_rate, 64)
            self.segment[[SEG_X, SEG_Y, SEG_HEADING]] = tgt.x, tgt.y, tgt.heading
            self.segment[SEG_YAW_RATE] = self._draws[0]
            self.segment[SEG_NEXT_DRAW] = 1
        self.time = 0.0
        self.tally = np.zeros(N_TALLY)
        obs = scenario.obstacles
        self._ids = np.array([o.id for o in obs], dtype=int)
        self._agents, self._waypoints = agent_arrays(obs, seed)
        self._agent_state = np.zeros((len(obs), N_AGENT_STATE))
        agents_begin(self._agents, self._agent_state)
        self._agent_steps = 0.0
        self._stepped = bool(stepped(self._agents))
        self._radius = np.array([o.radius for o in obs], dtype=float)
        self._positions = np.zeros((len(obs), 2))
        self._velocities = np.zeros((len(obs), 2))
        self._robot = (math.nan, math.nan)

    def warm_up(self) -> None:
        """Load the compiled kernels now, on a copy (its own generator too), so the first tick is on time."""
        twin = copy.deepcopy(self)
        twin.advance_to(max(self.time, 1.0))
        twin.target()
        twin.obstacles()
        twin.assess(0.0, 0.0)

    @property
    def collision_count(self) -> int:
        return int(self.tally[W_COLLISIONS])

    @property
    def capture_radius(self) -> float:
        """Distance at which the target counts as reached [m]; 0 without a target."""
        tgt = self.scenario.target
        return tgt.capture_radius if tgt is not None else 0.0

    def advance_to(self, t: float, robot_xy: tuple[float, float] | None = None) -> None:
        """Move the world forward to time t [s] (never backwards); the obstacles that react see the robot at
        `robot_xy` [m] (None: where it was last given; never given: they do not see it)."""
        if t < self.time:
            raise ValueError(f"world time cannot go back: {t} < {self.time}")
        self.time = t
        if robot_xy is not None:
            self._robot = (float(robot_xy[0]), float(robot_xy[1]))
        if self._stepped:
            self._agent_steps = agents_advance(self._agents, self._waypoints, self._agent_state, self._agent_steps,
                                               float(t), self._robot[0], self._robot[1], float(self.robot_radius))
        tgt = self.scenario.target
        if tgt is None:
            return
        while not advance_segments(self.segment, self._draws, t, tgt.speed, tgt.turn_interval):
            self._draws = np.concatenate([self._draws, yaw_rate_draws(self._rng, tgt.max_yaw_rate, len(self._draws))])

    def target(self) -> TargetState | None:
        tgt = self.scenario.target
        if tgt is None:
            return None
        x, y, heading, _vx, _vy = target_at(self.segment, tgt.speed, self.time)
        return TargetState(x, y, heading, tgt.speed, float(self.segment[SEG_YAW_RATE]))

    def _locate(self) -> None:
        agents_at(self._agents, self._agent_state, self._agent_steps, float(self.time), self._positions,
                  self._velocities)

    def obstacle_positions(self) -> np.ndarray:
        self._locate()
        return self._positions.copy()

    def obstacles(self) -> list[ObstacleSpec]:
        """The obstacles now: positions and velocities at the world's time, and radii."""
        self._locate()
        return [
            ObstacleSpec(int(i), float(p[0]), float(p[1]), float(v[0]), float(v[1]), float(r))
            for i, p, v, r in zip(self._ids, self._positions, self._velocities, self._radius, strict=True)
        ]

    def assess(self, robot_x: float, robot_y: float) -> Assessment:
        """Collision, clearance and target distance for the robot at (robot_x, robot_y); counts collisions."""
        tgt = self.target()
        target_distance = math.inf if tgt is None else math.hypot(tgt.x - robot_x, tgt.y - robot_y)
        self._locate()
        clearance, hit = assess_obstacles(self._positions, self._radius, self.robot_radius, float(robot_x),
                                          float(robot_y), self.tally)
        return Assessment(
            collision=hit >= 0,
            collision_obstacle_id=int(self._ids[hit]) if hit >= 0 else -1,
            clearance=clearance,
            target_distance=target_distance,
            target_reached=tgt is not None and target_distance <= self.scenario.target.capture_radius,
        )
