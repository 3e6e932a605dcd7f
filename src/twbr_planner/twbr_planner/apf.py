"""The paper's artificial potential field planner (eqs. 19-28) as a plain numpy core.

Forces (the robot follows their sum's direction):
- attractive (eq. 21): K_p (p_tar - p_rob) + K_v (v_tar - v_rob), Ge & Cui's relative-velocity field;
- repulsive per obstacle (eq. 23) inside the detection range rho_o: K_o [ (1/d^2)(1/d - 1/rho_o) - (d - rho_o) ]
  along the unit vector from the obstacle's centre to the robot, d being the distance to the obstacle's
  surface (minus the robot's footprint radius, so d is the clearance).
Potential (eq. 24), the same terms integrated: U_att = K_p/2 |p_tar - p|^2 (+ K_v/2 |v_tar - v|^2, constant
over positions) and U_rep = K_o/2 [ (1/d - 1/rho_o)^2 + (d - rho_o)^2 ] inside rho_o. The paper prints eq. 22
with a minus before (d - rho_o)^2, which is not the integral of its eq. 23 and would dig a potential well
around every obstacle at the edge of the detection range; we keep the force of eq. 23 and the potential
whose negative gradient it is (a test checks F = -grad U numerically).
Commands: heading alpha = atan2(F_y, F_x) (eq. 26); omega = K_s wrap(alpha - psi), limited (eq. 27);
v = v_max away from obstacles and v_max d/rho_o inside the range (eq. 28, whose printed conditions are
swapped), then also limited near a static target (approach_gain * distance) and in sharp turns
(cos of the heading error, never negative) so the robot turns before it drives.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from twbr_common.geometry import wrap_angle


class Mode(Enum):
    TRACKING = "tracking"  # driving to the target, no obstacle in range
    AVOIDING = "avoiding"  # an obstacle inside the detection range
    ARRIVED = "arrived"  # static target inside the capture radius: stopped, balancing
    FOLLOWING = "following"  # moving target inside the capture radius: kept there
    STUCK = "stuck"  # no progress towards the target for stuck_time: a local minimum (reported, not hidden)
    STALE = "stale"  # target or obstacle data too old: stopped
    NO_TARGET = "no_target"  # nothing to go to yet: stopped


@dataclass(frozen=True)
class Obstacles:
    """Circular obstacles: positions (N, 2) [m], radii (N,) [m], ids (N,)."""

    positions: np.ndarray
    radii: np.ndarray
    ids: np.ndarray

    @staticmethod
    def empty() -> Obstacles:
        return Obstacles(np.empty((0, 2)), np.empty(0), np.empty(0, dtype=int))

    @staticmethod
    def of(items: list[tuple[int, float, float, float]]) -> Obstacles:
        """From (id, x, y, radius) tuples."""
        if not items:
            return Obstacles.empty()
        a = np.array(items, dtype=float)
        return Obstacles(a[:, 1:3], a[:, 3], a[:, 0].astype(int))


def attractive_force(p_rob: np.ndarray, v_rob: np.ndarray, p_tar: np.ndarray, v_tar: np.ndarray, k_p: float,
                     k_v: float) -> np.ndarray:
    """Eq. 21."""
    return k_p * (np.asarray(p_tar) - p_rob) + k_v * (np.asarray(v_tar) - v_rob)


def surface_distances(points: np.ndarray, obstacles: Obstacles, robot_radius: float) -> np.ndarray:
    """Clearance from each point (..., 2) to each obstacle's surface: (..., N) [m]."""
    centre = np.linalg.norm(np.asarray(points)[..., None, :] - obstacles.positions, axis=-1)
    return centre - obstacles.radii - robot_radius


def repulsive_magnitude(d: np.ndarray, k_o: float, rho_o: float, d_min: float) -> np.ndarray:
    """Eq. 23 along the distance; zero outside rho_o; d below d_min (touching) counts as d_min."""
    d = np.maximum(np.asarray(d, dtype=float), d_min)
    inside = d <= rho_o
    return np.where(inside, k_o * ((1.0 / d**2) * (1.0 / d - 1.0 / rho_o) - (d - rho_o)), 0.0)


def repulsive_force(p_rob: np.ndarray, obstacles: Obstacles, k_o: float, rho_o: float, robot_radius: float,
                    d_min: float) -> tuple[np.ndarray, np.ndarray]:
    """Sum of eq. 23 over the obstacles, pointing from each obstacle to the robot; also the distances."""
    if len(obstacles.radii) == 0:
        return np.zeros(2), np.empty(0)
    away = np.asarray(p_rob) - obstacles.positions
    centre = np.linalg.norm(away, axis=1)
    d = centre - obstacles.radii - robot_radius
    unit = away / np.maximum(centre, 1e-9)[:, None]
    magnitude = repulsive_magnitude(d, k_o, rho_o, d_min)
    return (magnitude[:, None] * unit).sum(axis=0), d


def attractive_potential(points: np.ndarray, p_tar: np.ndarray, k_p: float, k_v: float = 0.0,
                         relative_velocity: np.ndarray | None = None) -> np.ndarray:
    """Eq. 19 at each point (..., 2); the velocity term does not depend on position."""
    diff = np.asarray(p_tar) - np.asarray(points)
    u = 0.5 * k_p * np.sum(diff**2, axis=-1)
    if relative_velocity is not None:
        u = u + 0.5 * k_v * float(np.sum(np.asarray(relative_velocity) ** 2))
    return u


def repulsive_potential(points: np.ndarray, obstacles: Obstacles, k_o: float, rho_o: float, robot_radius: float,
                        d_min: float) -> np.ndarray:
    """The potential whose negative gradient is eq. 23, summed over the obstacles, at each point (..., 2)."""
    if len(obstacles.radii) == 0:
        return np.zeros(np.asarray(points).shape[:-1])
    d = np.maximum(surface_distances(points, obstacles, robot_radius), d_min)
    u = np.where(d <= rho_o, 0.5 * k_o * ((1.0 / d - 1.0 / rho_o) ** 2 + (d - rho_o) ** 2), 0.0)
    return u.sum(axis=-1)


def potential(points: np.ndarray, p_tar: np.ndarray, obstacles: Obstacles, g: Mapping[str, Any]) -> np.ndarray:
    """Eq. 24 over a grid of points (..., 2) with the planner's parameters `g`."""
    return attractive_potential(points, p_tar, g["k_p"]) + repulsive_potential(
        points, obstacles, g["k_o"], g["rho_o"], g["robot_radius"], g["min_distance"])


def speed_command(nearest_distance: float, rho_o: float, v_max: float) -> float:
    """Eq. 28 with its conditions the right way round: v_max outside the range, v_max d / rho_o inside."""
    if nearest_distance > rho_o:
        return v_max
    return v_max * max(nearest_distance, 0.0) / rho_o


def yaw_rate_command(desired_heading: float, yaw: float, k_s: float, limit: float) -> tuple[float, float]:
    """Eq. 27 on the wrapped heading error; returns (omega, heading error)."""
    error = wrap_angle(desired_heading - yaw)
    return min(max(k_s * error, -limit), limit), error


@dataclass(frozen=True)
class Target:
    x: float
    y: float
    vx: float
    vy: float

    @property
    def moving(self) -> bool:
        return math.hypot(self.vx, self.vy) > 1e-3


@dataclass(frozen=True)
class PlannerOutput:
    stamp: float
    attractive_force: np.ndarray
    repulsive_force: np.ndarray
    total_force: np.ndarray
    desired_heading: float
    heading_error: float
    velocity_cmd: float
    yaw_rate_cmd: float
    distance_to_target: float
    nearest_obstacle_distance: float
    nearest_obstacle_id: int
    mode: Mode


class ApfPlanner:
    """Eqs. 19-28 plus arrival, following and a stuck (local minimum) report."""

    def __init__(self, g: Mapping[str, Any]) -> None:
        self.g = dict(g)
        self._progress: deque[tuple[float, float, float, float]] = deque()  # (t, distance, x, y)
        self._last: tuple[float, float, float] | None = None  # (stamp, v, omega) commanded

    def reset(self) -> None:
        self._progress.clear()
        self._last = None

    def _smooth(self, stamp: float, v: float, omega: float) -> tuple[float, float]:
        """Acceleration limits (a velocity smoother): a balancing robot must lean to accelerate, so a
        speed step is a pitch transient; these keep |pitch| within about a/g of upright."""
        if self._last is not None and stamp > self._last[0]:
            dt = stamp - self._last[0]
            dv, dw = self.g["max_acceleration"] * dt, self.g["max_yaw_acceleration"] * dt
            v = min(max(v, self._last[1] - dv), self._last[1] + dv)
            omega = min(max(omega, self._last[2] - dw), self._last[2] + dw)
        elif self._last is not None:
            v, omega = self._last[1], self._last[2]
        else:
            # The first command starts from rest, like every later one from the previous command.
            v = min(max(v, -self.g["max_acceleration"] * 0.05), self.g["max_acceleration"] * 0.05)
            omega = min(max(omega, -self.g["max_yaw_acceleration"] * 0.05), self.g["max_yaw_acceleration"] * 0.05)
        self._last = (stamp, v, omega)
        return v, omega

    def stopped(self, stamp: float, mode: Mode) -> PlannerOutput:
        zero = np.zeros(2)
        return PlannerOutput(stamp, zero, zero, zero, math.nan, math.nan, 0.0, 0.0, math.nan, math.inf, -1, mode)

    def step(self, stamp: float, x: float, y: float, yaw: float, speed: float, target: Target | None,
             obstacles: Obstacles) -> PlannerOutput:
        g = self.g
        if target is None:
            return self.stopped(stamp, Mode.NO_TARGET)
        p = np.array([x, y])
        v_rob = speed * np.array([math.cos(yaw), math.sin(yaw)])
        p_tar = np.array([target.x, target.y])
        f_att = attractive_force(p, v_rob, p_tar, np.array([target.vx, target.vy]), g["k_p"], g["k_v"])
        f_rep, d = repulsive_force(p, obstacles, g["k_o"], g["rho_o"], g["robot_radius"], g["min_distance"])
        total = f_att + f_rep
        nearest = int(np.argmin(d)) if len(d) else -1
        nearest_d = float(d[nearest]) if nearest >= 0 else math.inf
        nearest_id = int(obstacles.ids[nearest]) if nearest >= 0 else -1
        distance = float(np.linalg.norm(p_tar - p))
        alpha = math.atan2(total[1], total[0])
        omega, error = yaw_rate_command(alpha, yaw, g["k_s"], g["max_yaw_rate"])
        v = speed_command(nearest_d, g["rho_o"], g["v_max"])
        if g["slow_in_turns"]:
            v *= max(0.0, math.cos(error))
        mode = Mode.AVOIDING if nearest_d <= g["rho_o"] else Mode.TRACKING
        if distance <= g["capture_radius"]:
            if target.moving:
                mode = Mode.FOLLOWING
            else:
                self._progress.clear()
                v, omega = self._smooth(stamp, 0.0, 0.0)
                return PlannerOutput(stamp, f_att, f_rep, total, alpha, error, v, omega, distance, nearest_d,
                                     nearest_id, Mode.ARRIVED)
        if not target.moving:
            v = min(v, g["approach_gain"] * distance)
        if mode is not Mode.FOLLOWING and self._stuck(stamp, distance, x, y, target.moving):
            mode = Mode.STUCK
        v, omega = self._smooth(stamp, v, omega)
        return PlannerOutput(stamp, f_att, f_rep, total, alpha, error, v, omega, distance, nearest_d, nearest_id,
                             mode)

    def _stuck(self, stamp: float, distance: float, x: float, y: float, moving_target: bool) -> bool:
        """No progress over stuck_time: the robot moved less than stuck_progress, or (static target) the
        distance to it shrank by less than that. A robot following a moving target is not stuck."""
        window = self.g["stuck_time"]
        self._progress.append((stamp, distance, x, y))
        while len(self._progress) > 1 and self._progress[1][0] <= stamp - window:
            self._progress.popleft()
        first_t, first_d, first_x, first_y = self._progress[0]
        if stamp - first_t < window:
            return False
        little = self.g["stuck_progress"]
        return math.hypot(x - first_x, y - first_y) < little or (not moving_target and first_d - distance < little)
