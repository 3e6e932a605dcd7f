"""How the world's obstacles move: straight lines, waypoint routes, wandering, and people who react.

Each obstacle has one motion kind and, optionally, a reaction (every kind may react):

- `straight` (the paper's): constant velocity, p(t) = p0 + v t, exact at any t.
- `waypoints`: towards each waypoint in turn at `speed`, pausing `pause` s at each, looping or stopping
  at the last (a person going between desks, a cart on its route).
- `wander`: the paper's target's random turns (a yaw rate redrawn uniformly in +-`max_yaw_rate` every
  `turn_interval` s), with the speed redrawn within +-`speed_change` of `speed`, a stop of `stop_time` s
  with probability `stop_probability` at each draw (stop and go), and a turn back home beyond
  `roam_radius` of the start (0: unbounded).
- reaction `social` (Helbing & Molnár 1995, "Social force model for pedestrian dynamics", Phys. Rev. E
  51(5)): the kind's velocity is the agent's desired one, which it relaxes towards in `relaxation_time`,
  pushed away from the robot and every other obstacle by A exp((r_ij - d_ij) / B) along the line between
  them, weighted by lambda + (1 - lambda)(1 + cos phi)/2 (what is behind it counts less: eq. 4 of the
  paper). The robot's push is scaled by `attention` (0: it does not see the robot at all), so people avoid
  the robot and each other, but not perfectly; the speed is held below 1.3 times the desired speed
  (Helbing's v_max = 1.3 v0).

Every kind but an unreacting `straight` is integrated in steps of STEP seconds at t = k STEP; between steps an agent
moves at its step's velocity. A reacting agent's step takes the robot's pose the world was last given
(the simulator gives its true pose at every sample; `world_node` the odom pose). Random draws are a
counter-based hash of (seed, obstacle id, draw index, channel), not a generator's stream, so the batch
engine draws the same numbers as the World without storing them. No rclpy: the World (sim_node,
world_node, the headless runs) and the batch engine call these same kernels.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.social_force import helbing_push

STEP = 0.05  # [s] the integration step of every kind but straight
MOTIONS = ("straight", "waypoints", "wander")
REACTIONS = ("none", "social")
STRAIGHT = 0
WAYPOINTS = 1
WANDER = 2
SPEED_CAP = 1.3  # a social agent's speed stays below this times its desired speed (Helbing's v_max)
ARRIVAL = 0.3  # [m] a reacting agent is at its waypoint this near (it may be pushed off the exact point)

# One obstacle's motion: what the scenario file says of it (velocity: the straight kind's).
AGENT_LAYOUT = Layout((
    "motion", "x0", "y0", "vx", "vy", "radius", "speed", "heading", "loop", "pause", "max_yaw_rate",
    "turn_interval", "speed_change", "stop_probability", "stop_time", "roam_radius", "social", "attention",
    "strength", "range", "relaxation_time", "anisotropy", "n_waypoints", "id", "seed",
))
AP_MOTION = AGENT_LAYOUT["motion"]
AP_X0 = AGENT_LAYOUT["x0"]
AP_Y0 = AGENT_LAYOUT["y0"]
AP_VX = AGENT_LAYOUT["vx"]
AP_VY = AGENT_LAYOUT["vy"]
AP_RADIUS = AGENT_LAYOUT["radius"]
AP_SPEED = AGENT_LAYOUT["speed"]
AP_HEADING = AGENT_LAYOUT["heading"]
AP_LOOP = AGENT_LAYOUT["loop"]
AP_PAUSE = AGENT_LAYOUT["pause"]
AP_MAX_YAW_RATE = AGENT_LAYOUT["max_yaw_rate"]
AP_TURN_INTERVAL = AGENT_LAYOUT["turn_interval"]
AP_SPEED_CHANGE = AGENT_LAYOUT["speed_change"]
AP_STOP_PROBABILITY = AGENT_LAYOUT["stop_probability"]
AP_STOP_TIME = AGENT_LAYOUT["stop_time"]
AP_ROAM_RADIUS = AGENT_LAYOUT["roam_radius"]
AP_SOCIAL = AGENT_LAYOUT["social"]
AP_ATTENTION = AGENT_LAYOUT["attention"]
AP_STRENGTH = AGENT_LAYOUT["strength"]
AP_RANGE = AGENT_LAYOUT["range"]
AP_RELAXATION_TIME = AGENT_LAYOUT["relaxation_time"]
AP_ANISOTROPY = AGENT_LAYOUT["anisotropy"]
AP_N_WAYPOINTS = AGENT_LAYOUT["n_waypoints"]
AP_ID = AGENT_LAYOUT["id"]
AP_SEED = AGENT_LAYOUT["seed"]
N_AGENT = len(AGENT_LAYOUT)
# Where an agent is in its motion: position [m], velocity [m/s], the heading and speed it wants [rad, m/s],
# its yaw rate [rad/s] (wander), the waypoint it heads for, until when it stands still [s], when its next
# draw is due [s] and the index of that draw.
AGENT_STATE_LAYOUT = Layout((
    "x", "y", "vx", "vy", "heading", "speed", "yaw_rate", "waypoint", "still_until", "next_draw_t", "draw",
))
AX_X = AGENT_STATE_LAYOUT["x"]
AX_Y = AGENT_STATE_LAYOUT["y"]
AX_VX = AGENT_STATE_LAYOUT["vx"]
AX_VY = AGENT_STATE_LAYOUT["vy"]
AX_HEADING = AGENT_STATE_LAYOUT["heading"]
AX_SPEED = AGENT_STATE_LAYOUT["speed"]
AX_YAW_RATE = AGENT_STATE_LAYOUT["yaw_rate"]
AX_WAYPOINT = AGENT_STATE_LAYOUT["waypoint"]
AX_STILL_UNTIL = AGENT_STATE_LAYOUT["still_until"]
AX_NEXT_DRAW_T = AGENT_STATE_LAYOUT["next_draw_t"]
AX_DRAW = AGENT_STATE_LAYOUT["draw"]
N_AGENT_STATE = len(AGENT_STATE_LAYOUT)
# Draw channels: the yaw rate, the speed, whether it stops.
DRAW_YAW_RATE = 0
DRAW_SPEED = 1
DRAW_STOP = 2
_MASK32 = 0xFFFFFFFF


@kernel
def _hash32(x):
    """A 32-bit integer hash (Wellons' lowbias32): every input bit moves every output bit."""
    x = x & _MASK32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & _MASK32
    x ^= x >> 15
    x = (x * 0x846CA68B) & _MASK32
    x ^= x >> 16
    return x


@kernel
def uniform_draw(seed, obstacle_id, k, channel):
    """The k-th draw of one channel of one obstacle of the world of `seed`, uniform in [0, 1)."""
    h = _hash32(int(seed) ^ 0x5EED1234)
    h = _hash32(h ^ int(obstacle_id))
    h = _hash32(h ^ (int(k) * 4 + int(channel)))
    return h / 4294967296.0


@kernel
def analytic(spec, i):
    """Whether agent i moves on its straight line whatever happens (p0 + v t at any t, never stepped)."""
    return spec[i, AP_MOTION] == STRAIGHT and spec[i, AP_SOCIAL] == 0.0


@kernel
def reacts(spec):
    """Whether any agent reacts (its step wants the robot's pose)."""
    for i in range(spec.shape[0]):  # noqa: SIM110 (numba compiles no generator)
        if spec[i, AP_SOCIAL] != 0.0:
            return True
    return False


@kernel
def stepped(spec):
    """Whether any agent is stepped (moves other than on a fixed straight line)."""
    for i in range(spec.shape[0]):  # noqa: SIM110 (numba compiles no generator)
        if not analytic(spec, i):
            return True
    return False


@kernel
def agents_begin(spec, state):
    """Every agent at its start: at rest where the file puts it (straight: at its velocity)."""
    for i in range(spec.shape[0]):
        state[i, :] = 0.0
        state[i, AX_X] = spec[i, AP_X0]
        state[i, AX_Y] = spec[i, AP_Y0]
        state[i, AX_HEADING] = spec[i, AP_HEADING]
        state[i, AX_SPEED] = spec[i, AP_SPEED]
        if spec[i, AP_MOTION] == STRAIGHT:
            state[i, AX_VX] = spec[i, AP_VX]
            state[i, AX_VY] = spec[i, AP_VY]
        state[i, AX_NEXT_DRAW_T] = 0.0  # wander: the first draw at t = 0


@kernel
def _wander_draw(spec, state, i, t):
    """The draws due by t: a new yaw rate and speed, and perhaps a stop."""
    while state[i, AX_NEXT_DRAW_T] <= t + 1e-9:
        k = state[i, AX_DRAW]
        seed = spec[i, AP_SEED]
        oid = spec[i, AP_ID]
        state[i, AX_YAW_RATE] = spec[i, AP_MAX_YAW_RATE] * (2.0 * uniform_draw(seed, oid, k, DRAW_YAW_RATE) - 1.0)
        state[i, AX_SPEED] = spec[i, AP_SPEED] * (
            1.0 + spec[i, AP_SPEED_CHANGE] * (2.0 * uniform_draw(seed, oid, k, DRAW_SPEED) - 1.0))
        if k > 0 and uniform_draw(seed, oid, k, DRAW_STOP) < spec[i, AP_STOP_PROBABILITY]:
            state[i, AX_STILL_UNTIL] = state[i, AX_NEXT_DRAW_T] + spec[i, AP_STOP_TIME]
        state[i, AX_DRAW] = k + 1.0
        state[i, AX_NEXT_DRAW_T] += spec[i, AP_TURN_INTERVAL]


@kernel
def _desired_velocity(spec, waypoints, state, i, t):
    """(vx, vy): the velocity the agent's motion kind wants at time t (and its waypoint bookkeeping)."""
    if t < state[i, AX_STILL_UNTIL]:
        return 0.0, 0.0
    kind = spec[i, AP_MOTION]
    x = state[i, AX_X]
    y = state[i, AX_Y]
    if kind == WAYPOINTS:
        n = int(spec[i, AP_N_WAYPOINTS])
        w = int(state[i, AX_WAYPOINT])
        if w >= n:
            return 0.0, 0.0  # at the end of a route that does not loop
        dx = waypoints[i, w, 0] - x
        dy = waypoints[i, w, 1] - y
        d = math.hypot(dx, dy)
        speed = spec[i, AP_SPEED]
        arrival = ARRIVAL if spec[i, AP_SOCIAL] != 0.0 else speed * STEP
        if d <= arrival + 1e-12:
            w += 1
            if w >= n and spec[i, AP_LOOP] != 0.0:
                w = 0
            state[i, AX_WAYPOINT] = w
            if spec[i, AP_PAUSE] > 0.0:
                state[i, AX_STILL_UNTIL] = t + spec[i, AP_PAUSE]
            if spec[i, AP_SOCIAL] == 0.0:  # exactly at the waypoint, this step's motion taken up by arriving
                return dx / STEP, dy / STEP
            return 0.0, 0.0
        state[i, AX_HEADING] = math.atan2(dy, dx)
        step = min(speed, d / STEP) if spec[i, AP_SOCIAL] == 0.0 else speed
        return step * dx / d, step * dy / d
    if kind == WANDER:
        _wander_draw(spec, state, i, t)
        if t < state[i, AX_STILL_UNTIL]:
            return 0.0, 0.0
        heading = state[i, AX_HEADING]
        roam = spec[i, AP_ROAM_RADIUS]
        if roam > 0.0:
            hx = spec[i, AP_X0] - x
            hy = spec[i, AP_Y0] - y
            if hx * hx + hy * hy > roam * roam:
                # beyond its range it turns home at its largest yaw rate
                error = math.atan2(hy, hx) - heading
                error = math.atan2(math.sin(error), math.cos(error))
                turn = spec[i, AP_MAX_YAW_RATE] * STEP
                heading += min(max(error, -turn), turn)
            else:
                heading += state[i, AX_YAW_RATE] * STEP
        else:
            heading += state[i, AX_YAW_RATE] * STEP
        state[i, AX_HEADING] = heading
        return state[i, AX_SPEED] * math.cos(heading), state[i, AX_SPEED] * math.sin(heading)
    return spec[i, AP_VX], spec[i, AP_VY]


@kernel
def _push(spec, i, x, y, heading, other_x, other_y, reach):
    """Helbing's repulsion on agent i at (x, y) from a disc at (other_x, other_y) whose surface is `reach`
    from the centre of one touching agent i (twbr_common.social_force)."""
    return helbing_push(spec[i, AP_STRENGTH], spec[i, AP_RANGE], spec[i, AP_ANISOTROPY], x, y, math.cos(heading),
                        math.sin(heading), other_x, other_y, reach)


@kernel
def agents_step(spec, waypoints, state, t, robot_x, robot_y, robot_radius):
    """Every stepped agent from t to t + STEP; the robot at (robot_x, robot_y) (NaN: unknown, none reacts
    to it)."""
    n = spec.shape[0]
    desired = np.zeros((n, 2))
    for i in range(n):
        if not analytic(spec, i):
            desired[i, 0], desired[i, 1] = _desired_velocity(spec, waypoints, state, i, t)
    robot_known = not (math.isnan(robot_x) or math.isnan(robot_y))
    for i in range(n):
        if analytic(spec, i):
            continue
        vx = desired[i, 0]
        vy = desired[i, 1]
        if spec[i, AP_SOCIAL] != 0.0:
            x = state[i, AX_X]
            y = state[i, AX_Y]
            heading = state[i, AX_HEADING]
            tau = spec[i, AP_RELAXATION_TIME]
            ax = (vx - state[i, AX_VX]) / tau
            ay = (vy - state[i, AX_VY]) / tau
            for j in range(n):
                if j == i:
                    continue
                px, py = _push(spec, i, x, y, heading, state[j, AX_X], state[j, AX_Y],
                               spec[i, AP_RADIUS] + spec[j, AP_RADIUS])
                ax += px
                ay += py
            if robot_known and spec[i, AP_ATTENTION] > 0.0:
                px, py = _push(spec, i, x, y, heading, robot_x, robot_y, spec[i, AP_RADIUS] + robot_radius)
                ax += spec[i, AP_ATTENTION] * px
                ay += spec[i, AP_ATTENTION] * py
            vx = state[i, AX_VX] + ax * STEP
            vy = state[i, AX_VY] + ay * STEP
            cap = SPEED_CAP * max(spec[i, AP_SPEED], math.hypot(desired[i, 0], desired[i, 1]))
            speed = math.hypot(vx, vy)
            if speed > cap:
                vx *= cap / speed
                vy *= cap / speed
        state[i, AX_VX] = vx
        state[i, AX_VY] = vy
    for i in range(n):
        if not analytic(spec, i):
            state[i, AX_X] += state[i, AX_VX] * STEP
            state[i, AX_Y] += state[i, AX_VY] * STEP


@kernel
def agents_advance(spec, waypoints, state, steps, t, robot_x, robot_y, robot_radius):
    """The steps due by time t (k STEP <= t), from `steps` done; returns the steps done then."""
    while (steps + 1.0) * STEP <= t + 1e-9:
        agents_step(spec, waypoints, state, steps * STEP, robot_x, robot_y, robot_radius)
        steps += 1.0
    return steps


@kernel
def agents_at(spec, state, steps, t, positions, velocities):
    """Every obstacle's position and velocity at time t (not before the last step), into the (n, 2) arrays."""
    since = t - steps * STEP
    for i in range(spec.shape[0]):
        if analytic(spec, i):
            positions[i, 0] = spec[i, AP_X0] + spec[i, AP_VX] * t
            positions[i, 1] = spec[i, AP_Y0] + spec[i, AP_VY] * t
        else:
            positions[i, 0] = state[i, AX_X] + state[i, AX_VX] * since
            positions[i, 1] = state[i, AX_Y] + state[i, AX_VY] * since
        velocities[i, 0] = state[i, AX_VX]
        velocities[i, 1] = state[i, AX_VY]


def agent_arrays(obstacles: Sequence, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(spec (n, N_AGENT), waypoints (n, w, 2)) of a scenario's obstacles (ObstacleSpec) in the world of
    `seed`; w is at least 1."""
    n = len(obstacles)
    spec = np.zeros((n, N_AGENT))
    widest = max([len(o.motion.waypoints) for o in obstacles if o.motion is not None] + [1])
    waypoints = np.zeros((n, widest, 2))
    for i, o in enumerate(obstacles):
        row = spec[i]
        row[[AP_X0, AP_Y0, AP_VX, AP_VY, AP_RADIUS, AP_ID, AP_SEED]] = o.x, o.y, o.vx, o.vy, o.radius, o.id, seed
        row[AP_SPEED] = math.hypot(o.vx, o.vy)
        row[AP_HEADING] = math.atan2(o.vy, o.vx)
        m = o.motion
        if m is None:
            continue
        row[AP_MOTION] = MOTIONS.index(m.kind)
        row[[AP_SPEED, AP_HEADING, AP_LOOP, AP_PAUSE, AP_MAX_YAW_RATE, AP_TURN_INTERVAL, AP_SPEED_CHANGE,
             AP_STOP_PROBABILITY, AP_STOP_TIME, AP_ROAM_RADIUS]] = (
            m.speed, m.heading, m.loop, m.pause, m.max_yaw_rate, m.turn_interval, m.speed_change,
            m.stop_probability, m.stop_time, m.roam_radius)
        row[AP_N_WAYPOINTS] = len(m.waypoints)
        if m.waypoints:
            waypoints[i, : len(m.waypoints)] = m.waypoints
        if m.kind != "straight":
            row[[AP_VX, AP_VY]] = 0.0
        r = o.reaction
        if r is not None:
            row[[AP_SOCIAL, AP_ATTENTION, AP_STRENGTH, AP_RANGE, AP_RELAXATION_TIME, AP_ANISOTROPY]] = (
                1.0, r.attention, r.strength, r.range, r.relaxation_time, r.anisotropy)
    return spec, waypoints
