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

`apf_step` is the one implementation of a planning step, compiled: `ApfPlanner` (the node, the headless
runs) and the batch engine call it on a settings vector (A_*), a memory vector (R_*), a ring buffer of
recent progress and an output vector (Q_*) per robot. The numpy functions below serve figures and tests
of the equations, on the same scalar kernels.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from twbr_common.geometry import wrap_angle
from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import default_of
from twbr_planner.planner_params import APF_SPECS, METHODS
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS


class Mode(Enum):
    TRACKING = "tracking"  # driving to the target, no obstacle in range
    AVOIDING = "avoiding"  # an obstacle inside the detection range
    ARRIVED = "arrived"  # static target inside the capture radius: stopped, balancing
    FOLLOWING = "following"  # moving target inside the capture radius: kept there
    STUCK = "stuck"  # no progress towards the target for stuck_time: a local minimum (reported, not hidden)
    STALE = "stale"  # target or obstacle data too old: stopped
    NO_TARGET = "no_target"  # nothing to go to yet: stopped
    ESCAPING = "escaping"  # robust: following an obstacle's boundary out of a local minimum
    EVADING = "evading"  # robust: stepping out of a moving obstacle's path
    YIELDING = "yielding"  # robust: waiting, stepping aside or backing out for what is coming


MODES = tuple(Mode)  # a mode's code in the kernels is its index here
TRACKING, AVOIDING, ARRIVED, FOLLOWING, STUCK, STALE, NO_TARGET, ESCAPING, EVADING, YIELDING = range(len(MODES))
PAPER, ROBUST, DWA, VO = range(len(METHODS))  # a method's code in the settings vector

# Settings vector: planner_params.APF_SPECS by name (the method by its code).
SETTINGS_LAYOUT = Layout(spec.name for spec in APF_SPECS)
A_METHOD = SETTINGS_LAYOUT["method"]
A_K_P = SETTINGS_LAYOUT["k_p"]
A_K_V = SETTINGS_LAYOUT["k_v"]
A_K_O = SETTINGS_LAYOUT["k_o"]
A_RHO_O = SETTINGS_LAYOUT["rho_o"]
A_K_S = SETTINGS_LAYOUT["k_s"]
A_V_MAX = SETTINGS_LAYOUT["v_max"]
A_MAX_YAW_RATE = SETTINGS_LAYOUT["max_yaw_rate"]
A_ROBOT_RADIUS = SETTINGS_LAYOUT["robot_radius"]
A_MIN_DISTANCE = SETTINGS_LAYOUT["min_distance"]
A_CAPTURE_RADIUS = SETTINGS_LAYOUT["capture_radius"]
A_APPROACH_GAIN = SETTINGS_LAYOUT["approach_gain"]
A_SLOW_IN_TURNS = SETTINGS_LAYOUT["slow_in_turns"]
A_MAX_ACCELERATION = SETTINGS_LAYOUT["max_acceleration"]
A_MAX_YAW_ACCELERATION = SETTINGS_LAYOUT["max_yaw_acceleration"]
A_MAX_YAW_JERK = SETTINGS_LAYOUT["max_yaw_jerk"]
A_EVASION_YAW_JERK = SETTINGS_LAYOUT["evasion_yaw_jerk"]
A_STUCK_TIME = SETTINGS_LAYOUT["stuck_time"]
A_STUCK_PROGRESS = SETTINGS_LAYOUT["stuck_progress"]
A_REPULSION_RANGE = SETTINGS_LAYOUT["repulsion_range"]
A_GOAL_FADE = SETTINGS_LAYOUT["goal_fade"]
A_FOLLOW_RANGE = SETTINGS_LAYOUT["follow_range"]
A_FOLLOW_CLEARANCE = SETTINGS_LAYOUT["follow_clearance"]
A_EVADE_HORIZON = SETTINGS_LAYOUT["evade_horizon"]
A_EVADE_MARGIN = SETTINGS_LAYOUT["evade_margin"]
A_EVADE_GAIN = SETTINGS_LAYOUT["evade_gain"]
A_SPEED_POLICY = SETTINGS_LAYOUT["speed_policy"]
A_SAFETY_FILTER = SETTINGS_LAYOUT["safety_filter"]
A_SAFETY_GAMMA = SETTINGS_LAYOUT["safety_gamma"]
A_SAFETY_MARGIN = SETTINGS_LAYOUT["safety_margin"]
A_SAFETY_LOOKAHEAD = SETTINGS_LAYOUT["safety_lookahead"]
A_BRAKE_DECELERATION = SETTINGS_LAYOUT["brake_deceleration"]
A_DWA_HORIZON = SETTINGS_LAYOUT["dwa_horizon"]
A_DWA_HEADING_WEIGHT = SETTINGS_LAYOUT["dwa_heading_weight"]
A_DWA_CLEARANCE_WEIGHT = SETTINGS_LAYOUT["dwa_clearance_weight"]
A_DWA_SPEED_WEIGHT = SETTINGS_LAYOUT["dwa_speed_weight"]
A_DWA_CLEARANCE_CAP = SETTINGS_LAYOUT["dwa_clearance_cap"]
A_VO_HORIZON = SETTINGS_LAYOUT["vo_horizon"]
A_YIELD_HORIZON = SETTINGS_LAYOUT["yield_horizon"]
A_YIELD_UNCERTAINTY = SETTINGS_LAYOUT["yield_uncertainty"]
A_YIELD_MARGIN = SETTINGS_LAYOUT["yield_margin"]
A_YIELD_DISCOUNT = SETTINGS_LAYOUT["yield_discount"]
A_WINDOW_HORIZON = SETTINGS_LAYOUT["window_horizon"]
A_WINDOW_MIN_SPEED = SETTINGS_LAYOUT["window_min_speed"]
A_WINDOW_MARGIN = SETTINGS_LAYOUT["window_margin"]
A_WINDOW_ACCELERATION = SETTINGS_LAYOUT["window_acceleration"]
A_WINDOW_LANE_ANGLE = SETTINGS_LAYOUT["window_lane_angle"]
A_WINDOW_HEADING_WEIGHT = SETTINGS_LAYOUT["window_heading_weight"]
A_WINDOW_CLEARANCE_WEIGHT = SETTINGS_LAYOUT["window_clearance_weight"]
A_WINDOW_SPEED_WEIGHT = SETTINGS_LAYOUT["window_speed_weight"]
A_WINDOW_CLEARANCE_CAP = SETTINGS_LAYOUT["window_clearance_cap"]
A_PREDICTION_STRENGTH = SETTINGS_LAYOUT["prediction_strength"]
A_PREDICTION_RANGE = SETTINGS_LAYOUT["prediction_range"]
A_PREDICTION_RELAXATION_TIME = SETTINGS_LAYOUT["prediction_relaxation_time"]
A_FOLLOW_GAIN = SETTINGS_LAYOUT["follow_gain"]
A_LEAVE_PROGRESS = SETTINGS_LAYOUT["leave_progress"]
A_FOLLOW_FLIP_TIME = SETTINGS_LAYOUT["follow_flip_time"]
A_FREE_MARGIN = SETTINGS_LAYOUT["free_margin"]
A_FREE_STEER = SETTINGS_LAYOUT["free_steer"]
A_WAY_LOOK = SETTINGS_LAYOUT["way_look"]
A_WAY_FAN_STEP = SETTINGS_LAYOUT["way_fan_step"]
A_WAY_FAN_STEPS = SETTINGS_LAYOUT["way_fan_steps"]
A_EVADE_SWITCH = SETTINGS_LAYOUT["evade_switch"]
A_REVERSE_BELOW = SETTINGS_LAYOUT["reverse_below"]
A_BEHIND_ANGLE = SETTINGS_LAYOUT["behind_angle"]
A_TURNING_YAW_RATE = SETTINGS_LAYOUT["turning_yaw_rate"]
A_SAFETY_SPEED_SAMPLES = SETTINGS_LAYOUT["safety_speed_samples"]
A_SAFETY_YAW_RATE_SAMPLES = SETTINGS_LAYOUT["safety_yaw_rate_samples"]
A_SAFETY_YAW_RATE_WEIGHT = SETTINGS_LAYOUT["safety_yaw_rate_weight"]
A_SAFETY_MOVING_NEAR = SETTINGS_LAYOUT["safety_moving_near"]
# Memory vector: the last command (for the acceleration limits), the progress ring's head and length, and
# the robust method's boundary following (on or off, side +1 / -1, distance to the target and time when
# it began, whether the last step found no progress, and the side of the last way round).
MEMORY_LAYOUT = Layout(("has_last", "last_stamp", "last_v", "last_omega", "last_yaw_acceleration", "head", "length", "following",
                        "follow_side", "hit_distance", "follow_since", "stalled", "way_side", "evade_threat",
                        "evade_side"))
R_HAS_LAST = MEMORY_LAYOUT["has_last"]
R_LAST_STAMP = MEMORY_LAYOUT["last_stamp"]
R_LAST_V = MEMORY_LAYOUT["last_v"]
R_LAST_OMEGA = MEMORY_LAYOUT["last_omega"]
R_LAST_YAW_ACCELERATION = MEMORY_LAYOUT["last_yaw_acceleration"]
R_HEAD = MEMORY_LAYOUT["head"]
R_LENGTH = MEMORY_LAYOUT["length"]
R_FOLLOWING = MEMORY_LAYOUT["following"]
R_FOLLOW_SIDE = MEMORY_LAYOUT["follow_side"]
R_HIT_DISTANCE = MEMORY_LAYOUT["hit_distance"]
R_FOLLOW_SINCE = MEMORY_LAYOUT["follow_since"]
R_STALLED = MEMORY_LAYOUT["stalled"]
R_WAY_SIDE = MEMORY_LAYOUT["way_side"]
R_EVADE_THREAT = MEMORY_LAYOUT["evade_threat"]
R_EVADE_SIDE = MEMORY_LAYOUT["evade_side"]
N_MEMORY = len(MEMORY_LAYOUT)
PROGRESS_COLUMNS = 4  # (t, distance, x, y) per planning step
# Output vector of one step.
OUTPUT_LAYOUT = Layout((
    "attractive_force_x", "attractive_force_y", "repulsive_force_x", "repulsive_force_y", "desired_heading",
    "heading_error", "velocity_cmd", "yaw_rate_cmd", "distance_to_target", "nearest_obstacle_distance",
    "nearest_obstacle_index", "mode", "escape_side", "threat_index", "active_constraint_index",
))
Q_F_ATT_X = OUTPUT_LAYOUT["attractive_force_x"]
Q_F_ATT_Y = OUTPUT_LAYOUT["attractive_force_y"]
Q_F_REP_X = OUTPUT_LAYOUT["repulsive_force_x"]
Q_F_REP_Y = OUTPUT_LAYOUT["repulsive_force_y"]
Q_ALPHA = OUTPUT_LAYOUT["desired_heading"]
Q_ERROR = OUTPUT_LAYOUT["heading_error"]
Q_V = OUTPUT_LAYOUT["velocity_cmd"]
Q_OMEGA = OUTPUT_LAYOUT["yaw_rate_cmd"]
Q_DISTANCE = OUTPUT_LAYOUT["distance_to_target"]
Q_NEAREST_D = OUTPUT_LAYOUT["nearest_obstacle_distance"]
Q_NEAREST_INDEX = OUTPUT_LAYOUT["nearest_obstacle_index"]
Q_MODE = OUTPUT_LAYOUT["mode"]
Q_ESCAPE_SIDE = OUTPUT_LAYOUT["escape_side"]  # robust: +1 / -1 while following a boundary, else 0
Q_THREAT = OUTPUT_LAYOUT["threat_index"]  # robust: the moving obstacle being evaded, -1 none
Q_ACTIVE_CONSTRAINT = OUTPUT_LAYOUT["active_constraint_index"]  # robust: the obstacle the safety filter bound, -1
N_OUTPUTS = len(OUTPUT_LAYOUT)
# [s] the first command's acceleration step: one period at the node's default rate.
FIRST_PERIOD = 1.0 / default_of(PLANNER_NODE_SPECS, "rate")


def settings_vector(g: Mapping[str, Any]) -> np.ndarray:
    """The planner's validated parameters (planner_params.APF_SPECS) in the kernel's layout."""
    return SETTINGS_LAYOUT.pack({**g, "method": METHODS.index(g["method"])})


def progress_capacity(stuck_time: float, rate: float) -> int:
    """Rows the progress ring needs at `rate` [Hz]: the window's steps, the one before it, the new one."""
    return math.ceil(stuck_time * rate) + 4


@dataclass(frozen=True)
class Obstacles:
    """Circular obstacles: positions (N, 2) [m], radii (N,) [m], ids (N,), velocities (N, 2) [m/s]."""

    positions: np.ndarray
    radii: np.ndarray
    ids: np.ndarray
    velocities: np.ndarray

    @staticmethod
    def empty() -> Obstacles:
        return Obstacles(np.empty((0, 2)), np.empty(0), np.empty(0, dtype=int), np.empty((0, 2)))

    @staticmethod
    def from_rows(rows: np.ndarray, age: float) -> Obstacles:
        """From an obstacle list's rows (id, x, y, vx, vy, radius: ObstacleArray's order), each moved along
        its velocity by age [s] (the list was made that long ago; a negative age counts as 0)."""
        if not len(rows):
            return Obstacles.empty()
        velocities = np.ascontiguousarray(rows[:, 3:5])
        return Obstacles(rows[:, 1:3] + velocities * max(0.0, age), rows[:, 5].copy(), rows[:, 0].astype(int),
                         velocities)

    @staticmethod
    def of(items: list[tuple[float, ...]]) -> Obstacles:
        """From (id, x, y, radius) or (id, x, y, radius, vx, vy) tuples (without a velocity: at rest)."""
        if not items:
            return Obstacles.empty()
        a = np.array([(*item, 0.0, 0.0) if len(item) == 4 else item for item in items], dtype=float)
        return Obstacles(np.ascontiguousarray(a[:, 1:3]), a[:, 3].copy(), a[:, 0].astype(int),
                         np.ascontiguousarray(a[:, 4:6]))


@kernel
def attraction(px, py, vx, vy, tx, ty, tvx, tvy, k_p, k_v):
    return k_p * (tx - px) + k_v * (tvx - vx), k_p * (ty - py) + k_v * (tvy - vy)


@kernel
def _repulsive_magnitude(d, k_o, rho_o, d_min):
    d = max(d, d_min)
    if d > rho_o:
        return 0.0
    return k_o * ((1.0 / d**2) * (1.0 / d - 1.0 / rho_o) - (d - rho_o))


@kernel
def repulsion(px, py, positions, radii, k_o, rho_o, robot_radius, d_min, distances, fade=1.0):
    """Eq. 23 summed over the obstacles (from each obstacle to the robot), each scaled by `fade` (the robust
    method's goal fade); clearances into `distances`."""
    fx = 0.0
    fy = 0.0
    for j in range(radii.shape[0]):
        ax = px - positions[j, 0]
        ay = py - positions[j, 1]
        centre = math.sqrt(ax * ax + ay * ay)
        d = centre - radii[j] - robot_radius
        distances[j] = d
        magnitude = fade * _repulsive_magnitude(d, k_o, rho_o, d_min)
        scale = max(centre, 1e-9)
        fx += magnitude * (ax / scale)
        fy += magnitude * (ay / scale)
    return fx, fy


@kernel
def clearances(px, py, positions, radii, robot_radius, distances):
    """Each obstacle's clearance from the footprint at (px, py) into `distances` [m]."""
    for j in range(radii.shape[0]):
        distances[j] = math.hypot(px - positions[j, 0], py - positions[j, 1]) - radii[j] - robot_radius


@kernel
def nearest_obstacle(distances):
    """(index, clearance) of the nearest obstacle; (-1, inf) without obstacles."""
    nearest = -1
    nearest_d = math.inf
    for j in range(distances.shape[0]):
        if distances[j] < nearest_d or nearest < 0:
            nearest = j
            nearest_d = distances[j]
    return nearest, nearest_d


@kernel
def speed_command(nearest_distance: float, rho_o: float, v_max: float) -> float:
    """Eq. 28 with its conditions the right way round: v_max outside the range, v_max d / rho_o inside."""
    if nearest_distance > rho_o:
        return v_max
    return v_max * max(nearest_distance, 0.0) / rho_o


@kernel
def yaw_rate_command(desired_heading: float, yaw: float, k_s: float, limit: float) -> tuple[float, float]:
    """Eq. 27 on the wrapped heading error; returns (omega, heading error)."""
    error = wrap_angle(desired_heading - yaw)
    return min(max(k_s * error, -limit), limit), error


def attractive_force(p_rob: np.ndarray, v_rob: np.ndarray, p_tar: np.ndarray, v_tar: np.ndarray, k_p: float,
                     k_v: float) -> np.ndarray:
    """Eq. 21."""
    return np.array(attraction(float(p_rob[0]), float(p_rob[1]), float(v_rob[0]), float(v_rob[1]),
                                float(p_tar[0]), float(p_tar[1]), float(v_tar[0]), float(v_tar[1]), k_p, k_v))


def repulsive_magnitude(d: Any, k_o: float, rho_o: float, d_min: float) -> Any:
    """Eq. 23 along the distance; zero outside rho_o; d below d_min (touching) counts as d_min."""
    if np.ndim(d) == 0:
        return _repulsive_magnitude(float(d), k_o, rho_o, d_min)
    flat = np.asarray(d, dtype=float).ravel()
    return np.array([_repulsive_magnitude(v, k_o, rho_o, d_min) for v in flat]).reshape(np.shape(d))


def repulsive_force(p_rob: np.ndarray, obstacles: Obstacles, k_o: float, rho_o: float, robot_radius: float,
                    d_min: float) -> tuple[np.ndarray, np.ndarray]:
    """Sum of eq. 23 over the obstacles, pointing from each obstacle to the robot; also the distances."""
    d = np.empty(len(obstacles.radii))
    f = repulsion(float(p_rob[0]), float(p_rob[1]), obstacles.positions, obstacles.radii, k_o, rho_o,
                   robot_radius, d_min, d)
    return np.array(f), d


def surface_distances(points: np.ndarray, obstacles: Obstacles, robot_radius: float) -> np.ndarray:
    """Clearance from each point (..., 2) to each obstacle's surface: (..., N) [m]."""
    centre = np.linalg.norm(np.asarray(points)[..., None, :] - obstacles.positions, axis=-1)
    return centre - obstacles.radii - robot_radius


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


@kernel
def command_period(m, stamp):
    """[s] since the last command: the step the acceleration limits allow for."""
    if m[R_HAS_LAST] != 0.0 and stamp > m[R_LAST_STAMP]:
        return stamp - m[R_LAST_STAMP]
    if m[R_HAS_LAST] != 0.0:
        return 0.0  # a repeated stamp repeats the last command
    return FIRST_PERIOD  # the first command starts from rest, like every later one from the previous one


@kernel
def yaw_rate_window(a, m, dt, jerk):
    """(lowest, highest) yaw rate [rad/s] the next command may take `dt` [s] after the last: within
    max_yaw_rate, within max_yaw_acceleration of the last command, and (`jerk` [rad/s³] > 0) with a yaw
    acceleration within jerk * dt of the last one. The controller's command hold follows the command stream's
    slope; where that slope reverses at once the yaw loop's proportional term steps the wheels' torque."""
    accel = a[A_MAX_YAW_ACCELERATION]
    lo = -accel
    hi = accel
    if jerk > 0.0:
        lo = min(max(m[R_LAST_YAW_ACCELERATION] - jerk * dt, -accel), accel)
        hi = max(min(m[R_LAST_YAW_ACCELERATION] + jerk * dt, accel), -accel)
    return (max(m[R_LAST_OMEGA] + lo * dt, -a[A_MAX_YAW_RATE]),
            min(m[R_LAST_OMEGA] + hi * dt, a[A_MAX_YAW_RATE]))


@kernel
def eased_yaw_rate(m, omega, dt, jerk):
    """The yaw rate on the way to `omega` whose acceleration can still be taken back to zero at `jerk`
    before it arrives (|acceleration| <= sqrt(2 jerk |error|)): a turn ends without overshoot."""
    if jerk <= 0.0 or dt <= 0.0:
        return omega
    error = omega - m[R_LAST_OMEGA]
    accel = min(abs(error) / dt, math.sqrt(2.0 * jerk * abs(error)))
    return m[R_LAST_OMEGA] + math.copysign(accel * dt, error)


@kernel
def limit_rates(a, m, stamp, v, omega, deceleration, jerk):
    """Acceleration limits (a velocity smoother): a balancing robot must lean to accelerate, so a
    speed step is a pitch transient; these keep |pitch| within about a/g of upright. The speed rises at
    most by max_acceleration and falls at most by `deceleration`; the yaw rate moves within
    yaw_rate_window (eased in at `jerk`); the memory takes the command."""
    dt = command_period(m, stamp)
    v = min(max(v, m[R_LAST_V] - deceleration * dt), m[R_LAST_V] + a[A_MAX_ACCELERATION] * dt)
    w_lo, w_hi = yaw_rate_window(a, m, dt, jerk)
    omega = min(max(eased_yaw_rate(m, omega, dt, jerk), w_lo), w_hi)
    if dt > 0.0:
        m[R_LAST_YAW_ACCELERATION] = (omega - m[R_LAST_OMEGA]) / dt
    m[R_HAS_LAST] = 1.0
    m[R_LAST_STAMP] = stamp
    m[R_LAST_V] = v
    m[R_LAST_OMEGA] = omega
    return v, omega


@kernel
def ramp_speed(a, v, v_goal, dt):
    """The speed `dt` [s] on from v towards v_goal at the acceleration limits: max_acceleration away from
    rest, brake_deceleration towards it (a rollout's model of the robot)."""
    if v_goal > v:
        return min(v_goal, v + (a[A_MAX_ACCELERATION] if v >= 0.0 else a[A_BRAKE_DECELERATION]) * dt)
    return max(v_goal, v - (a[A_BRAKE_DECELERATION] if v > 0.0 else a[A_MAX_ACCELERATION]) * dt)


@kernel
def _smooth(a, m, stamp, v, omega):
    """The paper method's limits: the same rate up and down, and no jerk limit (its field steers through the
    slew limit: with max_yaw_jerk its static run arrived 45.2 -> 53.3 s, benchmarks/HISTORY.md)."""
    return limit_rates(a, m, stamp, v, omega, a[A_MAX_ACCELERATION], 0.0)


@kernel
def no_progress(a, m, ring, stamp, distance, x, y, moving_target):
    """No progress over stuck_time: the robot moved less than stuck_progress, or (static target) the
    distance to it shrank by less than that. A robot following a moving target is not stuck."""
    capacity = ring.shape[0]
    head = int(m[R_HEAD])
    length = int(m[R_LENGTH])
    if length == capacity:
        raise ValueError("planner progress ring is full: size it with progress_capacity")
    row = (head + length) % capacity
    ring[row, 0] = stamp
    ring[row, 1] = distance
    ring[row, 2] = x
    ring[row, 3] = y
    length += 1
    window = a[A_STUCK_TIME]
    while length > 1 and ring[(head + 1) % capacity, 0] <= stamp - window:
        head = (head + 1) % capacity
        length -= 1
    m[R_HEAD] = head
    m[R_LENGTH] = length
    if stamp - ring[head, 0] < window:
        return False
    little = a[A_STUCK_PROGRESS]
    moved = math.hypot(x - ring[head, 2], y - ring[head, 3])
    return moved < little or (not moving_target and ring[head, 1] - distance < little)


@kernel
def arrive(a, m, distance, moving_target, mode, v, omega):
    """(mode, v, omega, arrived): a static target inside the capture radius is reached (stop, progress
    forgotten), a moving one there is followed; near a static one the speed is at most approach_gain *
    distance."""
    if distance <= a[A_CAPTURE_RADIUS]:
        if moving_target:
            return FOLLOWING, v, omega, False
        m[R_HEAD] = 0.0
        m[R_LENGTH] = 0.0
        return ARRIVED, 0.0, 0.0, True
    if not moving_target:
        v = min(v, a[A_APPROACH_GAIN] * distance)
    return mode, v, omega, False


@kernel
def top_speed(a, distance, moving_target):
    """[m/s] the fastest a sampling method may drive: v_max, and near a static target at most approach_gain *
    distance [m], as arrive() caps the field's speed."""
    return a[A_V_MAX] if moving_target else min(a[A_V_MAX], a[A_APPROACH_GAIN] * distance)


@kernel
def sampling_start(a, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions, radii, distances):
    """What a sampling method's step (dwa, vo) starts from: the attraction (eq. 22, recorded in the output),
    each obstacle's clearance into `distances`, the nearest one and its clearance [m], the target's distance
    [m] and whether it moves."""
    f_att_x, f_att_y = attraction(x, y, speed * math.cos(yaw), speed * math.sin(yaw), target_x, target_y,
                                  target_vx, target_vy, a[A_K_P], a[A_K_V])
    clearances(x, y, positions, radii, a[A_ROBOT_RADIUS], distances)
    nearest, nearest_d = nearest_obstacle(distances)
    return (f_att_x, f_att_y, nearest, nearest_d, math.hypot(target_x - x, target_y - y),
            math.hypot(target_vx, target_vy) > 1e-3)


@kernel
def sampling_finish(a, m, ring, out, stamp, x, y, distance, moving_target, nearest, nearest_d, f_att_x, f_att_y,
                    alpha, error, v, omega):
    """A sampling method's choice (v [m/s], omega [rad/s], towards alpha [rad]) through what every method
    shares: arrival, the stuck check, the rate limits, the output vector (Q_*)."""
    mode = AVOIDING if nearest_d <= a[A_RHO_O] else TRACKING
    mode, v, omega, arrived = arrive(a, m, distance, moving_target, mode, v, omega)
    if not arrived and mode != FOLLOWING and no_progress(a, m, ring, stamp, distance, x, y, moving_target):
        mode = STUCK
    v, omega = limit_rates(a, m, stamp, v, omega, a[A_BRAKE_DECELERATION], a[A_MAX_YAW_JERK])
    write_output(out, f_att_x, f_att_y, 0.0, 0.0, alpha, error, v, omega, distance, nearest_d, nearest, mode, 0.0,
                 -1.0, -1.0)


@kernel
def write_output(out, f_att_x, f_att_y, f_rep_x, f_rep_y, alpha, error, v, omega, distance, nearest_d, nearest, mode,
                 escape_side, threat, binding):
    """One planning step's output vector (Q_*)."""
    out[Q_F_ATT_X] = f_att_x
    out[Q_F_ATT_Y] = f_att_y
    out[Q_F_REP_X] = f_rep_x
    out[Q_F_REP_Y] = f_rep_y
    out[Q_ALPHA] = alpha
    out[Q_ERROR] = error
    out[Q_V] = v
    out[Q_OMEGA] = omega
    out[Q_DISTANCE] = distance
    out[Q_NEAREST_D] = nearest_d
    out[Q_NEAREST_INDEX] = nearest
    out[Q_MODE] = mode
    out[Q_ESCAPE_SIDE] = escape_side
    out[Q_THREAT] = threat
    out[Q_ACTIVE_CONSTRAINT] = binding


@kernel
def apf_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions, radii,
             distances):
    """One planning step towards a target into `out` (Q_*): eqs. 21-28, arrival, following, stuck, smoothing."""
    vx = speed * math.cos(yaw)
    vy = speed * math.sin(yaw)
    f_att_x, f_att_y = attraction(x, y, vx, vy, target_x, target_y, target_vx, target_vy, a[A_K_P], a[A_K_V])
    f_rep_x, f_rep_y = repulsion(x, y, positions, radii, a[A_K_O], a[A_RHO_O], a[A_ROBOT_RADIUS],
                                  a[A_MIN_DISTANCE], distances)
    total_x = f_att_x + f_rep_x
    total_y = f_att_y + f_rep_y
    nearest, nearest_d = nearest_obstacle(distances)
    distance = math.hypot(target_x - x, target_y - y)
    alpha = math.atan2(total_y, total_x)
    omega, error = yaw_rate_command(alpha, yaw, a[A_K_S], a[A_MAX_YAW_RATE])
    v = speed_command(nearest_d, a[A_RHO_O], a[A_V_MAX])
    if a[A_SLOW_IN_TURNS] != 0.0:
        v *= max(0.0, math.cos(error))
    mode = AVOIDING if nearest_d <= a[A_RHO_O] else TRACKING
    moving_target = math.hypot(target_vx, target_vy) > 1e-3
    mode, v, omega, arrived = arrive(a, m, distance, moving_target, mode, v, omega)
    if not arrived and mode != FOLLOWING and no_progress(a, m, ring, stamp, distance, x, y, moving_target):
        mode = STUCK
    v, omega = _smooth(a, m, stamp, v, omega)
    write_output(out, f_att_x, f_att_y, f_rep_x, f_rep_y, alpha, error, v, omega, distance, nearest_d, nearest, mode,
                 0.0, -1.0, -1.0)
