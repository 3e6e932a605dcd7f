"""The robust potential-field planner (`method: robust`): the paper's field, and what its failures call for.

It keeps the paper's attraction (eq. 21) and repulsion (eq. 23) and steers along their sum, with five
additions, each switched off by one parameter for the ablation study (docs/planner.md says where each
comes from):

1. Goal-reachable repulsion (Ge & Cui 2000): the repulsion is scaled by min(1, (rho_g / goal_fade)^2),
   rho_g the distance to the target, so it vanishes at the target and a target next to an obstacle is
   reachable. It also acts only within `repulsion_range` of a surface (not the detection range): a gap
   the robot fits through is not closed by its edges' fields. While the way to the target is free, the
   repulsion only steers sideways (its component against the target's direction is dropped).
2. An escape out of local minima that guarantees progress: when the straight way to the target is
   blocked within `follow_range`, or the field pushes away from it, or the progress detector finds
   none, the robot descends a navigation function (twbr_planner.navigation: a cost-to-go over a grid of
   the static obstacles, which has no minimum but the target) and leaves it once it is closer to the
   target than where it started and the way towards the target is free (TangentBug's rule). Where no
   way leads to the target it follows the obstacles' boundary instead (the tangent of the repulsion, at
   `follow_clearance`, on the side nearer the target's direction).
3. Dynamic repulsion (after Ge & Cui 2002): a moving obstacle whose closest approach, at the current
   relative velocity, comes within `evade_margin` of the robot's footprint in less than `evade_horizon`
   pushes the robot sideways out of its swept path, early, instead of braking in it.
4. A speed policy for a robot that must lean to brake: at most the speed from which `brake_deceleration`
   stops the robot before the first static obstacle ahead and before the nearest one (it may turn
   towards it), and never slowed by a moving obstacle it is evading.
5. A safety filter: a control barrier function per obstacle on a point `safety_lookahead` ahead of the
   axle (where both v and omega act), h = |q - p_j|^2 - R_j^2, requiring dh/dt + gamma h >= 0 with the
   obstacle's velocity; the admissible (v, omega) nearest the field's command, within the acceleration
   limits of one planning period, is chosen among a grid of candidates (or, when none is admissible,
   the one that violates least).

Everything is compiled and shared with the batch engine, like the paper's `apf_step`.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.geometry import wrap_angle
from twbr_common.jit import kernel
from twbr_planner.apf import (
    A_BRAKE_DECELERATION,
    A_EVADE_GAIN,
    A_EVADE_HORIZON,
    A_EVADE_MARGIN,
    A_FOLLOW_CLEARANCE,
    A_FOLLOW_RANGE,
    A_GOAL_FADE,
    A_K_O,
    A_K_P,
    A_K_S,
    A_K_V,
    A_MAX_ACCELERATION,
    A_MAX_YAW_ACCELERATION,
    A_MAX_YAW_RATE,
    A_MIN_DISTANCE,
    A_REPULSION_RANGE,
    A_RHO_O,
    A_ROBOT_RADIUS,
    A_SAFETY_FILTER,
    A_SAFETY_GAMMA,
    A_SAFETY_LOOKAHEAD,
    A_SAFETY_MARGIN,
    A_SLOW_IN_TURNS,
    A_SPEED_POLICY,
    A_V_MAX,
    AVOIDING,
    ESCAPING,
    EVADING,
    FOLLOWING,
    R_EVADE_SIDE,
    R_EVADE_THREAT,
    R_FOLLOW_SIDE,
    R_FOLLOW_SINCE,
    R_FOLLOWING,
    R_HIT_DISTANCE,
    R_LAST_OMEGA,
    R_LAST_V,
    R_STALLED,
    R_WAY_SIDE,
    STUCK,
    TRACKING,
    YIELDING,
    arrive,
    attraction,
    command_period,
    limit_rates,
    nearest_obstacle,
    no_progress,
    repulsion,
    write_output,
)
from twbr_planner.navigation import navigation_direction
from twbr_planner.yielding import yield_command

FREE_MARGIN = 0.05  # [m] the way is free when it passes every footprint-inflated obstacle by this much
FREE_STEER = 0.3  # on a free way the repulsion is at most this fraction of the attraction
WAY_LOOK = 1.4  # [m] a way round must be free this far (or to the target)
FAN_STEP = math.pi / 24  # [rad] between the directions tried for a way round
FAN_STEPS = 10  # on each side: up to 75 degrees from the target's direction
FOLLOW_GAIN = 2.0  # [1/m] how hard boundary following corrects its distance to the boundary
LEAVE_PROGRESS = 0.2  # [m] boundary following ends this much closer to the target than it began
FOLLOW_FLIP = 40.0  # [s] boundary following on one side this long without leaving turns to the other side
V_CANDIDATES = 5  # the safety filter's grid of forward speeds within one period's acceleration
OMEGA_CANDIDATES = 11  # and of yaw rates
OMEGA_WEIGHT = 0.1  # [s^2] cost of a yaw-rate change against a speed change
MOVING_NEAR = 0.5  # [m] the safety filter guards against an obstacle faster than the robot only this near
EVADE_SWITCH = 0.3  # [m] a dead-on obstacle is passed on the side first chosen until the other is this clearer
BEHIND = math.pi - 0.5  # [rad] a way further round than this is nearly behind the robot
TURNING = 0.05  # [rad/s] a robot turning faster than this keeps its turn's direction towards a way behind it
REVERSE_BELOW = 0.05  # [m/s] evading, a robot slower than this may back away
VIOLATION_TIE = 1e-6  # [m^2/s] violations this close count as equal


@kernel
def ray_clearance(x, y, ux, uy, positions, radii, inflate, reach, moving, skip_moving):
    """Distance along the unit direction (ux, uy) from (x, y) to the first obstacle inflated by `inflate`,
    within `reach` (reach when none); obstacles flagged in `moving` are left out when skip_moving."""
    first = reach
    for j in range(radii.shape[0]):
        if skip_moving and moving[j]:
            continue
        ox = positions[j, 0] - x
        oy = positions[j, 1] - y
        along = ox * ux + oy * uy
        r = radii[j] + inflate
        across2 = ox * ox + oy * oy - along * along
        if across2 >= r * r:
            continue
        inside = math.sqrt(r * r - across2)
        entry = along - inside
        if along + inside <= 0.0:
            continue  # behind
        first = min(first, max(entry, 0.0))
    return first


@kernel
def boundary_normal(x, y, positions, radii, robot_radius, reach):
    """Unit vector away from the obstacles within `reach` of the footprint (weighted by closeness), and the
    smallest clearance among them; (0, 0, inf) when none is that close."""
    nx = 0.0
    ny = 0.0
    nearest = math.inf
    for j in range(radii.shape[0]):
        ax = x - positions[j, 0]
        ay = y - positions[j, 1]
        centre = max(math.sqrt(ax * ax + ay * ay), 1e-9)
        d = centre - radii[j] - robot_radius
        if d > reach:
            continue
        w = 1.0 / (max(d, 0.02) + 0.05) ** 2
        nx += w * ax / centre
        ny += w * ay / centre
        nearest = min(nearest, d)
    norm = math.hypot(nx, ny)
    if norm < 1e-12:
        return 0.0, 0.0, nearest
    return nx / norm, ny / norm, nearest


@kernel
def reachable_distance(speed, tau, acceleration, v_max):
    """[m] the robot drives in tau [s] from `speed`, accelerating at `acceleration` up to v_max."""
    speed = min(abs(speed), v_max)
    t_top = (v_max - speed) / acceleration
    if tau <= t_top:
        return speed * tau + 0.5 * acceleration * tau * tau
    return (v_max * v_max - speed * speed) / (2.0 * acceleration) + v_max * (tau - t_top)


@kernel
def closest_approach(x, y, vx, vy, position, velocity):
    """(tau [s], miss [m], out_x, out_y): when the robot, at its velocity relative to a moving obstacle's,
    passes it closest, how close (centre to centre), and the unit direction from the obstacle to the robot
    then, the way that widens the miss (Ge & Cui's dynamic repulsion acts along it); tau = inf when they
    do not approach."""
    px = x - position[0]
    py = y - position[1]
    wx = vx - velocity[0]
    wy = vy - velocity[1]
    ww = wx * wx + wy * wy
    if ww < 1e-9:
        return math.inf, math.hypot(px, py), 0.0, 0.0
    tau = -(px * wx + py * wy) / ww
    if tau <= 0.0:
        return math.inf, math.hypot(px, py), 0.0, 0.0
    cx = px + wx * tau
    cy = py + wy * tau
    miss = math.hypot(cx, cy)
    if miss > 1e-3:
        return tau, miss, cx / miss, cy / miss
    speed = math.sqrt(ww)
    return tau, miss, wy / speed, -wx / speed  # dead on: pass it on the right of the relative motion


@kernel
def evasion(a, m, x, y, vx, vy, positions, velocities, radii, moving):
    """Ge & Cui's dynamic repulsion, as a direction: the sum over threatening moving obstacles of the
    direction that widens the closest approach, each weighted by its urgency (the distance the miss lacks,
    times evade_gain, over the distance the robot can drive before the closest approach, at most 1); the
    most urgent one's index (-1 none) and its own widening direction.

    An obstacle coming nearly dead on is passed on the side chosen when it first became the most urgent
    (kept in m) until the other side is EVADE_SWITCH clearer: the widening direction flips as the miss
    crosses zero, and a robot that follows each flip brakes and speeds up in the obstacle's path."""
    horizon = a[A_EVADE_HORIZON]
    ex = 0.0
    ey = 0.0
    threat = -1
    threat_x = 0.0
    threat_y = 0.0
    threat_side = 0.0
    urgent = 0.0
    if horizon <= 0.0:
        m[R_EVADE_SIDE] = 0.0
        return ex, ey, threat, threat_x, threat_y
    drive_speed = math.hypot(vx, vy)
    for j in range(radii.shape[0]):
        if not moving[j]:
            continue
        tau, miss, out_x, out_y = closest_approach(x, y, vx, vy, positions[j], velocities[j])
        reach = radii[j] + a[A_ROBOT_RADIUS] + a[A_EVADE_MARGIN]
        if tau > horizon or miss >= reach:
            continue
        # the side of the relative motion it passes on: +1 its right, -1 its left
        side = 1.0 if out_x * (vy - velocities[j, 1]) - out_y * (vx - velocities[j, 0]) >= 0.0 else -1.0
        if j == m[R_EVADE_THREAT] and m[R_EVADE_SIDE] != 0.0 and side != m[R_EVADE_SIDE] and miss < EVADE_SWITCH:
            out_x = -out_x
            out_y = -out_y
            miss = -miss
            side = -side
        drivable = reachable_distance(drive_speed, tau, a[A_MAX_ACCELERATION], a[A_V_MAX])
        weight = min(1.0, a[A_EVADE_GAIN] * (reach - miss) / max(drivable, 1e-6))
        ex += weight * out_x
        ey += weight * out_y
        if weight > urgent:
            urgent = weight
            threat = j
            threat_x = out_x
            threat_y = out_y
            threat_side = side
    m[R_EVADE_THREAT] = threat
    m[R_EVADE_SIDE] = threat_side
    return ex, ey, threat, threat_x, threat_y


@kernel
def safety_filter(a, stamp, m, x, y, yaw, v_nominal, omega_nominal, positions, velocities, radii, threat):
    """(v, omega, index of the binding obstacle or -1): the admissible command nearest the nominal one.

    The obstacle being evaded (`threat`, -1 none) is left to the evasion: a barrier on the distance alone
    would steer along a fast obstacle's path (away from it, for now) instead of out of it."""
    dt = command_period(m, stamp)
    dw = a[A_MAX_YAW_ACCELERATION] * dt
    # it reverses only when the command does (and then guards the point behind the axle)
    v_lo = max(m[R_LAST_V] - a[A_BRAKE_DECELERATION] * dt, min(0.0, v_nominal), -a[A_V_MAX])
    v_hi = min(m[R_LAST_V] + a[A_MAX_ACCELERATION] * dt, a[A_V_MAX])
    v_lo = min(v_lo, v_hi)  # a robot still reversing slows down first
    w_lo = max(m[R_LAST_OMEGA] - dw, -a[A_MAX_YAW_RATE])
    w_hi = min(m[R_LAST_OMEGA] + dw, a[A_MAX_YAW_RATE])
    v0 = min(max(v_nominal, v_lo), v_hi)
    w0 = min(max(omega_nominal, w_lo), w_hi)
    v_nominal = float(v_nominal)
    omega_nominal = float(omega_nominal)
    ex = math.cos(yaw)
    ey = math.sin(yaw)
    look = a[A_SAFETY_LOOKAHEAD] if v_nominal >= 0.0 else -a[A_SAFETY_LOOKAHEAD]
    qx = x + look * ex
    qy = y + look * ey
    gamma = a[A_SAFETY_GAMMA]
    # Each obstacle in range gives a constraint linear in the command: cv * A + cw * B + C >= 0; a robot
    # turning on the spot moves no part of its round footprint, so a command with cv = 0 is held to the
    # axle's own barrier D >= 0 instead (the point ahead would forbid the turn that leaves a boundary).
    # They are kept as (A, B, C, D, obstacle) tuples of floats: the same arithmetic compiled, and in the
    # interpreted node (TWBR_JIT=off) the candidate grid below works on Python floats, not numpy elements
    # (its time sits in the navigation graph's control latency at every plan: benchmarks/README.md).
    constraints = []
    n = radii.shape[0]
    for j in range(n):
        if j == threat:
            continue
        rx = qx - positions[j, 0]
        ry = qy - positions[j, 1]
        reach = radii[j] + a[A_ROBOT_RADIUS] + a[A_SAFETY_MARGIN]
        centre = math.sqrt(rx * rx + ry * ry)
        if centre - reach > a[A_RHO_O]:
            continue  # beyond the detection range
        if centre - reach > MOVING_NEAR and math.hypot(velocities[j, 0], velocities[j, 1]) > a[A_V_MAX]:
            # an obstacle faster than the robot is left to the evasion until it is near: a barrier on its
            # distance would turn the robot away from it, along its path, where it cannot outrun it
            continue
        px = x - positions[j, 0]
        py = y - positions[j, 1]
        constraints.append((
            float(2.0 * (rx * ex + ry * ey)),
            float(2.0 * look * (ry * ex - rx * ey)),
            float(-2.0 * (rx * velocities[j, 0] + ry * velocities[j, 1]) + gamma * (centre * centre - reach * reach)),
            float(-2.0 * (px * velocities[j, 0] + py * velocities[j, 1]) + gamma * (px * px + py * py - reach * reach)),
            j,
        ))
    if len(constraints) == 0:
        return v0, w0, -1
    best_v = v0
    best_w = w0
    best_cost = math.inf
    best_violation = math.inf
    best_binding = -1
    for i in range(V_CANDIDATES + 1):
        cv = float(v0 if i == V_CANDIDATES else v_lo + (v_hi - v_lo) * i / (V_CANDIDATES - 1))
        for k in range(OMEGA_CANDIDATES + 1):
            cw = float(w0 if k == OMEGA_CANDIDATES else w_lo + (w_hi - w_lo) * k / (OMEGA_CANDIDATES - 1))
            violation = 0.0
            slack = math.inf
            binding = -1
            for along, turn, const, axle, j in constraints:
                s = axle if cv == 0.0 else cv * along + cw * turn + const
                if s < 0.0:
                    violation -= s
                if s < slack:
                    slack = s
                    binding = j
            v_change = cv - v_nominal
            w_change = cw - omega_nominal
            cost = v_change * v_change + OMEGA_WEIGHT * (w_change * w_change)
            # the least total violation (none: admissible), and among equals the nearest the nominal command;
            # a constraint no candidate can help (a wall straight ahead while braking) leaves the steering free
            if violation < best_violation - VIOLATION_TIE or (
                    violation <= best_violation + VIOLATION_TIE and cost < best_cost):
                best_v = cv
                best_w = cw
                best_cost = cost
                best_violation = min(violation, best_violation)
                best_binding = binding
    changed = abs(best_v - v0) > 1e-12 or abs(best_w - w0) > 1e-12
    return best_v, best_w, best_binding if changed else -1


@kernel
def robust_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
                velocities, radii, distances):
    """One planning step of the robust method into `out` (Q_*)."""
    vx = speed * math.cos(yaw)
    vy = speed * math.sin(yaw)
    robot_radius = a[A_ROBOT_RADIUS]
    f_att_x, f_att_y = attraction(x, y, vx, vy, target_x, target_y, target_vx, target_vy, a[A_K_P], a[A_K_V])
    distance = math.hypot(target_x - x, target_y - y)
    moving_target = math.hypot(target_vx, target_vy) > 1e-3
    fade = 1.0
    if a[A_GOAL_FADE] > 0.0:
        fade = min(1.0, (distance / a[A_GOAL_FADE]) ** 2)
    # 1. repulsion within repulsion_range, faded towards the target; moving obstacles are flagged
    f_rep_x, f_rep_y = repulsion(x, y, positions, radii, a[A_K_O], a[A_REPULSION_RANGE], robot_radius,
                                  a[A_MIN_DISTANCE], distances, fade)
    moving = np.empty(radii.shape[0], dtype=np.bool_)
    nearest_static = math.inf
    for j in range(radii.shape[0]):
        moving[j] = math.hypot(velocities[j, 0], velocities[j, 1]) > 1e-3
        if not moving[j]:
            nearest_static = min(nearest_static, distances[j])
    nearest, nearest_d = nearest_obstacle(distances)
    # is the straight way to the target free (every obstacle where it is now, footprint and a margin)?
    att_norm = math.hypot(f_att_x, f_att_y)
    gx = f_att_x / att_norm if att_norm > 1e-12 else math.cos(yaw)
    gy = f_att_y / att_norm if att_norm > 1e-12 else math.sin(yaw)
    reach_goal = distance
    blocked_at = ray_clearance(x, y, gx, gy, positions, radii, robot_radius + FREE_MARGIN, reach_goal, moving, False)
    free = blocked_at >= reach_goal
    # A way round: when the straight way is blocked within WAY_LOOK, the direction nearest the target's
    # within the fan (the side taken last first) that is free for WAY_LOOK carries the attraction instead
    # (a virtual target on it), so that a gap beside the straight line is taken.
    look = min(reach_goal, WAY_LOOK)
    way_x = gx
    way_y = gy
    way_free = free or blocked_at >= look
    if not way_free:
        angle = math.atan2(gy, gx)
        first = m[R_WAY_SIDE] if m[R_WAY_SIDE] != 0.0 else 1.0
        for k in range(1, FAN_STEPS + 1):
            for turn in range(2):
                sign = first if turn == 0 else -first
                ux = math.cos(angle + sign * k * FAN_STEP)
                uy = math.sin(angle + sign * k * FAN_STEP)
                if ray_clearance(x, y, ux, uy, positions, radii, robot_radius + FREE_MARGIN, look, moving,
                                 False) >= look:
                    way_x = ux
                    way_y = uy
                    way_free = True
                    m[R_WAY_SIDE] = sign
                    break
            if way_free:
                break
    if way_free:
        # The way is free: the repulsion steers (at most FREE_STEER of the attraction, 17 degrees), it
        # neither holds the robot back nor turns it away from a target it can drive to.
        along = f_rep_x * way_x + f_rep_y * way_y
        if along < 0.0:
            f_rep_x -= along * way_x
            f_rep_y -= along * way_y
        ratio = math.hypot(f_rep_x, f_rep_y) / max(att_norm, 1e-12)
        if ratio > FREE_STEER:
            f_rep_x *= FREE_STEER / ratio
            f_rep_y *= FREE_STEER / ratio
    total_x = att_norm * way_x + f_rep_x
    total_y = att_norm * way_y + f_rep_y
    mode = AVOIDING if nearest_d <= a[A_RHO_O] else TRACKING
    # 2. boundary following out of a local minimum
    side = 0.0
    if a[A_FOLLOW_RANGE] > 0.0:
        nx, ny, near_boundary = boundary_normal(x, y, positions, radii, robot_radius, a[A_FOLLOW_RANGE])
        escape_x = 0.0
        escape_y = 0.0
        found = False
        if m[R_FOLLOWING] != 0.0:
            # TangentBug's leave rule: closer than where following began, and a free way towards the target
            # for WAY_LOOK (what lies beyond is met as it comes)
            if way_free and (distance < m[R_HIT_DISTANCE] - LEAVE_PROGRESS or moving_target):
                m[R_FOLLOWING] = 0.0
            else:  # the A* runs only while the escape goes on
                escape_x, escape_y, found = navigation_direction(x, y, target_x, target_y, positions, radii,
                                                                 moving, robot_radius + FREE_MARGIN)
                if found:
                    pass
                elif near_boundary == math.inf:
                    m[R_FOLLOWING] = 0.0  # no way and lost the boundary: back to the field
                elif stamp - m[R_FOLLOW_SINCE] > FOLLOW_FLIP:
                    m[R_FOLLOW_SIDE] = -m[R_FOLLOW_SIDE]
                    m[R_FOLLOW_SINCE] = stamp
                    m[R_HIT_DISTANCE] = distance
        elif near_boundary < math.inf and (
                (not way_free and blocked_at <= a[A_FOLLOW_RANGE] + robot_radius)  # no way, blocked close by
                or total_x * way_x + total_y * way_y < 0.0  # or the field pushes away from the way: a basin
                or m[R_STALLED] != 0.0):  # or the progress detector found none
            m[R_FOLLOWING] = 1.0
            m[R_HIT_DISTANCE] = distance
            m[R_FOLLOW_SINCE] = stamp
            # the side whose tangent is nearer the target's direction
            m[R_FOLLOW_SIDE] = 1.0 if (-ny * gx + nx * gy) >= 0.0 else -1.0
        if m[R_FOLLOWING] != 0.0 and found:
            # down the navigation function; the side is the one it passes the target's direction on
            side = 1.0 if gx * escape_y - gy * escape_x >= 0.0 else -1.0
            total_x = escape_x
            total_y = escape_y
            mode = ESCAPING
        elif m[R_FOLLOWING] != 0.0 and near_boundary < math.inf:
            side = m[R_FOLLOW_SIDE]
            tx = -ny * side
            ty = nx * side
            correction = FOLLOW_GAIN * (a[A_FOLLOW_CLEARANCE] - near_boundary)
            total_x = tx + correction * nx
            total_y = ty + correction * ny
            mode = ESCAPING
    # 3. dynamic repulsion: out of a moving obstacle's swept path, never towards the obstacle
    ex, ey, threat, out_x, out_y = evasion(a, m, x, y, vx, vy, positions, velocities, radii, moving)
    if threat >= 0:
        norm = math.hypot(total_x, total_y)
        base_x = total_x / norm if norm > 1e-12 else 0.0
        base_y = total_y / norm if norm > 1e-12 else 0.0
        to_x = positions[threat, 0] - x
        to_y = positions[threat, 1] - y
        to_norm = max(math.hypot(to_x, to_y), 1e-9)
        towards = (base_x * to_x + base_y * to_y) / to_norm
        if towards > 0.0:
            base_x -= towards * to_x / to_norm
            base_y -= towards * to_y / to_norm
        # nor so as to narrow its closest approach
        inwards = base_x * out_x + base_y * out_y
        if inwards < 0.0:
            base_x -= inwards * out_x
            base_y -= inwards * out_y
        urgency = min(1.0, math.hypot(ex, ey))
        total_x = (1.0 - urgency) * base_x + ex
        total_y = (1.0 - urgency) * base_y + ey
        mode = EVADING
    alpha = math.atan2(total_y, total_x)
    error = wrap_angle(alpha - yaw)
    # Out of a threat's path a robot that is (nearly) stopped backs away when the way out is behind it,
    # instead of turning on the spot first; one that drives on turns while it drives.
    direction = 1.0
    if threat >= 0 and abs(error) > 0.5 * math.pi and m[R_LAST_V] < REVERSE_BELOW:
        direction = -1.0
        error = wrap_angle(error + math.pi)
    # A way nearly behind is turned to the way the robot already turns: either way round is as short, and
    # a heading error dithering about +-pi (an evasion that nearly cancels the field) would reverse the
    # turn at every step.
    if abs(error) > BEHIND and m[R_LAST_OMEGA] * error < 0.0 and abs(m[R_LAST_OMEGA]) > TURNING:
        error -= math.copysign(2.0 * math.pi, error)
    omega = min(max(a[A_K_S] * error, -a[A_MAX_YAW_RATE]), a[A_MAX_YAW_RATE])
    # 4. speed
    v = a[A_V_MAX]
    if a[A_SLOW_IN_TURNS] != 0.0 and not (threat >= 0 and abs(error) < 0.5 * math.pi):
        v *= max(0.0, math.cos(error))  # turn before driving, except out of a threat's path
    if a[A_SPEED_POLICY] != 0.0:
        # able to stop before the first static obstacle ahead, and (the robot may turn towards any of them)
        # before the nearest static one; a moving obstacle being evaded does not slow the robot down
        ahead = ray_clearance(x, y, direction * math.cos(yaw), direction * math.sin(yaw), positions, radii,
                              robot_radius, a[A_RHO_O] * 4.0, moving, threat >= 0)
        room = min(ahead, nearest_static) - a[A_SAFETY_MARGIN]
        v = min(v, math.sqrt(2.0 * a[A_BRAKE_DECELERATION] * max(room, 0.0)))
    else:
        v = min(v, a[A_V_MAX] * max(min(nearest_d, a[A_RHO_O]), 0.0) / a[A_RHO_O])  # eq. 28
    v *= direction
    mode, v, omega, arrived = arrive(a, m, distance, moving_target, mode, v, omega)
    if arrived:
        m[R_FOLLOWING] = 0.0
    else:
        m[R_STALLED] = 0.0
        if mode != FOLLOWING and no_progress(a, m, ring, stamp, distance, x, y, moving_target):
            mode = STUCK
            m[R_STALLED] = 1.0  # the next step follows the boundary, if there is one
    # 5. yielding to what the look-ahead sees coming, then the safety filter and the acceleration limits' memory
    if not arrived:
        v, omega, yielding = yield_command(a, m, x, y, yaw, v, omega, target_x, target_y, positions, velocities,
                                           radii)
        if yielding:
            mode = YIELDING
    binding = -1
    if a[A_SAFETY_FILTER] != 0.0 and not arrived:
        v, omega, binding = safety_filter(a, stamp, m, x, y, yaw, v, omega, positions, velocities, radii, threat)
    v, omega = limit_rates(a, m, stamp, v, omega, a[A_BRAKE_DECELERATION])
    write_output(out, f_att_x, f_att_y, f_rep_x, f_rep_y, alpha, error, v, omega, distance, nearest_d, nearest, mode,
                 side, threat, binding)
