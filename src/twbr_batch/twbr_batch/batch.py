"""Batch engine: N robots at once through dynamics, motors, controller, planner and world, without ROS.

Each robot is the headless closed loop of `closed_loop` (the state at step k, the command computed from
it held until step k+1; the planner and the world's assessment at their own rates), compiled as one
kernel and run over the robot axis in parallel threads. It calls the very kernels the scalar cores and
so the nodes call (`dynamics.advance_upright`, `cascade.cascade_compute`, `planner.plan_step`, the world's
`advance_segments`, `target_at`, `obstacle_positions_at`, `assess_obstacles`, the scenario's
`command_profile_at`): there is no second copy of an equation to drift apart.

Like the headless closed loop, the batch exchanges every command (lockstep, no lost or stale message) and
reads an ideal IMU (no noise, no bias). A robot's run ends on its target (end_on_target), its fall, or the
scenario's duration; finished robots cost nothing while the others run on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twbr_common.jit import kernel, parallel_chunksize, parallel_kernel, prange
from twbr_common.layout import Layout
from twbr_common.params import ConfigError, default_of, defaults, validate_all
from twbr_common.timing import is_due, next_due
from twbr_control.cascade import K_ENABLED, O_LEFT, O_RIGHT, O_VELOCITY_REF, O_YAW_RATE_REF, cascade_compute
from twbr_control.cascade import N_OUTPUTS as N_CONTROL_OUTPUTS
from twbr_control.cascade import N_STATE as N_CONTROL_STATE
from twbr_control.cascade import settings_vector as control_vector
from twbr_control.controller_params import resolve as resolve_controller
from twbr_control.estimator import E_CALIBRATING, E_PITCH, E_PITCH_RATE, E_VELOCITY_ESTIMATE, estimator_update, uses_estimator
from twbr_control.estimator import N_MEMORY as N_ESTIMATOR_MEMORY
from twbr_control.estimator import settings_vector as estimator_vector
from twbr_planner.apf import (
    A_RHO_O,
    PROGRESS_COLUMNS,
    Q_DISTANCE,
    Q_MODE,
    Q_OMEGA,
    Q_V,
    STUCK,
    progress_capacity,
)
from twbr_planner.apf import N_MEMORY as N_PLANNER_MEMORY
from twbr_planner.apf import N_OUTPUTS as N_PLANNER_OUTPUTS
from twbr_planner.apf import settings_vector as planner_vector
from twbr_planner.planner import plan_step
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
from twbr_planner.planner_params import resolve as resolve_planner
from twbr_sim.dynamics import (
    N_STATE,
    S_PSI,
    S_PSID,
    S_TH,
    S_THD,
    S_XC,
    S_XD,
    S_YC,
    WORK_ROWS,
    advance_upright,
    derivatives,
    initial_state,
)
from twbr_sim.encoders import J_VELOCITY, J_X, J_Y, J_YAW, J_YAW_RATE, encoder_sample
from twbr_sim.encoders import N_OUTPUTS as N_ENCODER_OUTPUTS
from twbr_sim.encoders import new_memory as new_encoder_memory
from twbr_sim.encoders import settings_vector as encoder_vector
from twbr_sim.imu import IMU_STREAM, N_READING, R_ACCEL, R_GYRO, R_PITCH, imu_init, imu_sample
from twbr_sim.imu import new_memory as new_imu_memory
from twbr_sim.imu import settings_vector as imu_vector
from twbr_sim.noise import new_generator
from twbr_sim.robot_params import P_ROBOT_RADIUS, wheel_torque_limit
from twbr_sim.scenario import Scenario, command_profile, command_profile_at, vary
from twbr_sim.simulator import SENSOR_SPECS, SIM_SPECS, steps_per_publish
from twbr_sim.traction import N_OUTPUTS as N_TRACTION_OUTPUTS
from twbr_sim.traction import traction_flags, wheel_loads
from twbr_sim.world import (
    N_SEGMENT,
    N_TALLY,
    SEG_HEADING,
    SEG_NEXT_DRAW,
    SEG_X,
    SEG_Y,
    SEG_YAW_RATE,
    W_COLLISIONS,
    advance_segments,
    assess_obstacles,
    draws_needed,
    obstacle_positions_at,
    target_at,
    yaw_rate_draws,
)

WORLD_RATE = default_of(SIM_SPECS, "world_rate")  # [Hz] collisions and clearance are sampled at it
PLANNER_RATE = default_of(PLANNER_NODE_SPECS, "rate")  # [Hz]
PHYSICS_RATE = default_of(SIM_SPECS, "physics_rate")  # [Hz]

# What every robot of a batch shares besides the controller's and planner's settings: the step [s], the
# control period in physics steps, the samples of a run, the planner's and world's periods [s], whether
# there is a target and the run ends on it, the target's speed [m/s], turn interval [s] and capture
# radius [m], and the rows of the planner's progress ring.
RUN_LAYOUT = Layout((
    "h", "steps_per_control", "n_samples", "planner_period", "world_period", "has_target", "end_on_target",
    "target_speed", "turn_interval", "capture_radius", "ring_rows", "sensors", "estimate", "friction",
))
U_H = RUN_LAYOUT["h"]
U_STEPS_PER_CONTROL = RUN_LAYOUT["steps_per_control"]
U_N_SAMPLES = RUN_LAYOUT["n_samples"]
U_PLANNER_PERIOD = RUN_LAYOUT["planner_period"]
U_WORLD_PERIOD = RUN_LAYOUT["world_period"]
U_HAS_TARGET = RUN_LAYOUT["has_target"]
U_END_ON_TARGET = RUN_LAYOUT["end_on_target"]
U_TARGET_SPEED = RUN_LAYOUT["target_speed"]
U_TURN_INTERVAL = RUN_LAYOUT["turn_interval"]
U_CAPTURE_RADIUS = RUN_LAYOUT["capture_radius"]
U_RING_ROWS = RUN_LAYOUT["ring_rows"]
U_SENSORS = RUN_LAYOUT["sensors"]  # the sensors are not ideal: read them through their kernels
U_ESTIMATE = RUN_LAYOUT["estimate"]  # pitch (and speed) from the controller's estimator
U_FRICTION = RUN_LAYOUT["friction"]  # traction.friction: lift-off and slip are counted; 0: not counted
# Per-robot result columns.
# The first collision's obstacle (-1: none) and where the robot was when that obstacle last came into the
# detection range (t [s], x, y [m], yaw [rad], speed [m/s], yaw rate [rad/s]), for the avoidability check;
# the pitch's largest magnitude after the first 2 s; the distance to the target and whether the planner
# reported stuck at the last plan.
RESULT_LAYOUT = Layout((
    "reached_at", "collisions", "min_clearance", "pitch_min", "pitch_max", "fallen", "stuck_steps", "sim_time",
    "samples", "physics_steps", "hit_obstacle", ("detected", 6), "pitch_abs_max_settled", "final_distance",
    "stuck_at_end", "lift_events", "slip_events", "lifted_time", "slipping_time", "pitch_error_square_sum",
))
Z_REACHED_AT = RESULT_LAYOUT["reached_at"]
Z_COLLISIONS = RESULT_LAYOUT["collisions"]
Z_MIN_CLEARANCE = RESULT_LAYOUT["min_clearance"]
Z_PITCH_MIN = RESULT_LAYOUT["pitch_min"]
Z_PITCH_MAX = RESULT_LAYOUT["pitch_max"]
Z_FALLEN = RESULT_LAYOUT["fallen"]
Z_STUCK_STEPS = RESULT_LAYOUT["stuck_steps"]
Z_SIM_TIME = RESULT_LAYOUT["sim_time"]
Z_SAMPLES = RESULT_LAYOUT["samples"]
Z_PHYSICS_STEPS = RESULT_LAYOUT["physics_steps"]
Z_HIT_OBSTACLE = RESULT_LAYOUT["hit_obstacle"]
Z_DETECTED = RESULT_LAYOUT["detected"]  # t, x, y, yaw, speed, yaw rate
Z_PITCH_SETTLED = RESULT_LAYOUT["pitch_abs_max_settled"]
Z_FINAL_DISTANCE = RESULT_LAYOUT["final_distance"]
Z_STUCK_AT_END = RESULT_LAYOUT["stuck_at_end"]
Z_LIFT_EVENTS = RESULT_LAYOUT["lift_events"]
Z_SLIP_EVENTS = RESULT_LAYOUT["slip_events"]
Z_LIFTED_TIME = RESULT_LAYOUT["lifted_time"]  # [s]
Z_SLIPPING_TIME = RESULT_LAYOUT["slipping_time"]  # [s]
Z_PITCH_ERROR_SQUARES = RESULT_LAYOUT["pitch_error_square_sum"]  # sum over samples of (pitch used - true)^2
N_RESULT = len(RESULT_LAYOUT)
SETTLING_TIME = 2.0  # [s] the start's transient, left out of pitch_abs_max_settled
# Per-sample trace columns (recorded on request): time [s], axle centre [m], pitch [rad], forward speed
# [m/s], yaw [rad], the controller's wheel torque commands [N*m] and the references [m/s, rad/s].
TRACE_COLUMNS = ("t", "x_c", "y_c", "pitch", "velocity", "yaw", "left_torque", "right_torque", "velocity_ref",
                 "yaw_rate_ref", "pitch_true", "velocity_true")
TRACE_LAYOUT = Layout(TRACE_COLUMNS)
T_T = TRACE_LAYOUT["t"]
T_X_C = TRACE_LAYOUT["x_c"]
T_Y_C = TRACE_LAYOUT["y_c"]
T_PITCH = TRACE_LAYOUT["pitch"]
T_VELOCITY = TRACE_LAYOUT["velocity"]
T_YAW = TRACE_LAYOUT["yaw"]
T_LEFT_TORQUE = TRACE_LAYOUT["left_torque"]
T_RIGHT_TORQUE = TRACE_LAYOUT["right_torque"]
T_VELOCITY_REF = TRACE_LAYOUT["velocity_ref"]
T_YAW_RATE_REF = TRACE_LAYOUT["yaw_rate_ref"]
T_PITCH_TRUE = TRACE_LAYOUT["pitch_true"]  # the body's [rad] (pitch: what the controller used)
T_VELOCITY_TRUE = TRACE_LAYOUT["velocity_true"]  # the axle's [m/s] (velocity: what the controller used)
N_TRACE = len(TRACE_LAYOUT)


@kernel
def run_robot(p, state, c, a, run, segment, draws, obstacle_start, obstacle_velocity, radii, profile, result,
              trace, imu_c, imu_m, generator, encoder_c, encoder_m, estimator_q):
    """One robot's whole run, as run_closed_loop with the planner or the command profile as reference.

    p: robot parameters (robot_params.ROBOT_LAYOUT), state (dynamics.STATE_LAYOUT), c: controller settings
    (cascade.SETTINGS_LAYOUT), a: planner settings (apf.SETTINGS_LAYOUT), run: RUN_LAYOUT; the target's
    segment and yaw-rate draws, the obstacles' start [m], velocity [m/s] and radii [m], the command
    profile (three rows: t [s], v [m/s], omega [rad/s]); result: RESULT_LAYOUT; trace: rows of TRACE_LAYOUT;
    the sensors' settings and this robot's memories and generator (imu, encoders) and the estimator's settings,
    used when run[U_SENSORS] is set (ideal sensors read the state directly, as before).
    """
    h = run[U_H]
    steps_per_control = int(run[U_STEPS_PER_CONTROL])
    n_samples = int(run[U_N_SAMPLES])
    planner_period = run[U_PLANNER_PERIOD]
    world_period = run[U_WORLD_PERIOD]
    has_target = run[U_HAS_TARGET] != 0.0
    end_on_target = run[U_END_ON_TARGET] != 0.0
    target_speed = run[U_TARGET_SPEED]
    turn_interval = run[U_TURN_INTERVAL]
    capture_radius = run[U_CAPTURE_RADIUS]
    cmd_times = profile[0]
    cmd_speeds = profile[1]
    cmd_yaw_rates = profile[2]
    work = np.empty((WORK_ROWS, N_STATE))
    control = np.zeros(N_CONTROL_STATE)
    control[K_ENABLED] = 1.0
    control_out = np.empty(N_CONTROL_OUTPUTS)
    memory = np.zeros(N_PLANNER_MEMORY)
    ring = np.zeros((int(run[U_RING_ROWS]), PROGRESS_COLUMNS))
    plan_out = np.empty(N_PLANNER_OUTPUTS)
    tally = np.zeros(N_TALLY)
    positions = np.empty_like(obstacle_start)
    distances = np.empty(radii.shape[0])
    # per obstacle: inside the detection range at the last plan, and the robot's (t, x, y, yaw, speed,
    # yaw rate) when it last came in
    detected = np.zeros(radii.shape[0], dtype=np.bool_)
    detected_at = np.zeros((radii.shape[0], 6))
    hit_obstacle = -1
    hit_detected = np.full(6, math.nan)
    pitch_settled = 0.0
    final_distance = math.nan
    stuck_at_end = False
    torque_limit = wheel_torque_limit(p)
    robot_radius = p[P_ROBOT_RADIUS]
    record = trace.shape[0] > 0
    sensors = run[U_SENSORS] != 0.0
    estimate = run[U_ESTIMATE] != 0.0
    friction = run[U_FRICTION]
    derivative = np.zeros(N_STATE)
    reading = np.zeros(N_READING)
    odometry = np.zeros(N_ENCODER_OUTPUTS)
    loads = np.zeros(N_TRACTION_OUTPUTS)
    estimator_m = np.zeros(N_ESTIMATOR_MEMORY)
    if sensors:
        imu_init(imu_c, imu_m, generator)
    left = 0.0
    right = 0.0
    lifted = False
    slipping = False
    lift_events = 0
    slip_events = 0
    lifted_samples = 0
    slipping_samples = 0
    pitch_error_squares = 0.0

    step_count = 0
    fallen = False
    world_next = -math.inf
    plan_next = -math.inf
    v_ref = 0.0  # the references in effect (a plan's take effect from the next sample, as cmd_vel in the graph)
    w_ref = 0.0
    next_v = 0.0
    next_w = 0.0
    command_stamp = 0.0  # the sample from which the references in effect apply (a new plan's: the one after it)
    new_plan = False
    commanded = not has_target  # a planner's first command applies from the second sample: none before it
    reached_at = math.nan
    min_clearance = math.inf
    pitch_min = math.inf
    pitch_max = -math.inf
    stuck_steps = 0
    t = 0.0
    k = 0
    for k in range(n_samples):
        t = step_count * h
        x = state[S_XC]  # the truth, for the world's assessment
        y = state[S_YC]
        pitch = state[S_TH]  # an ideal IMU on the axle: the body's pitch and pitch rate
        pitch_rate = state[S_THD]
        odom_x = x  # what odom says, for the planner and the velocity loop
        odom_y = y
        odom_yaw = state[S_PSI]
        odom_velocity = state[S_XD]
        yaw_rate = state[S_PSID]
        if sensors or friction > 0.0:
            derivatives(p, state, left, right, derivative)  # under the command applied now
        if sensors:  # as Simulator.sense: the imu, then the encoders, once per state
            imu_sample(p, imu_c, imu_m, generator, state, derivative, reading)
            encoder_sample(p, encoder_c, encoder_m, state, odometry)
            odom_x = odometry[J_X]
            odom_y = odometry[J_Y]
            odom_yaw = odometry[J_YAW]
            odom_velocity = odometry[J_VELOCITY]
            yaw_rate = odometry[J_YAW_RATE]
            pitch = reading[R_PITCH]
            pitch_rate = reading[R_GYRO + 1]
            if estimate:
                estimator_update(estimator_q, estimator_m, t, pitch_rate, reading[R_ACCEL], reading[R_ACCEL + 2],
                                 odom_velocity)
                pitch = estimator_m[E_PITCH]
                pitch_rate = estimator_m[E_PITCH_RATE]
        if friction > 0.0:
            wheel_loads(p, state, derivative, loads)
            now_lifted, now_slipping = traction_flags(loads, friction)
            lift_events += 1 if now_lifted and not lifted else 0
            slip_events += 1 if now_slipping and not slipping else 0
            lifted_samples += 1 if now_lifted else 0
            slipping_samples += 1 if now_slipping else 0
            lifted = now_lifted
            slipping = now_slipping
        pitch_error_squares += (pitch - state[S_TH]) ** 2
        # the velocity loop's speed: odom's, or the estimator's fused one
        velocity = estimator_m[E_VELOCITY_ESTIMATE] if estimate else odom_velocity
        if is_due(t, world_next):  # the world's assessment, at the world rate
            world_next = next_due(t, world_next, world_period)
            obstacle_positions_at(obstacle_start, obstacle_velocity, t, positions)
            collisions_before = tally[W_COLLISIONS]
            clearance, hit = assess_obstacles(positions, radii, robot_radius, x, y, tally)
            min_clearance = min(min_clearance, clearance)
            if hit_obstacle < 0 and tally[W_COLLISIONS] > collisions_before:
                hit_obstacle = hit
                if detected[hit]:
                    hit_detected[:] = detected_at[hit]
                else:  # it came into range and hit between two plans: the robot now
                    hit_detected[:] = (t, x, y, state[S_PSI], state[S_XD], state[S_PSID])
            if has_target and math.isnan(reached_at):
                tx, ty, _heading, _vx, _vy = target_at(segment, target_speed, t)
                if math.hypot(tx - x, ty - y) <= capture_radius:
                    reached_at = t
        if has_target:
            if is_due(t, plan_next):  # the planner, at its rate, on the world at time t
                plan_next = next_due(t, plan_next, planner_period)
                tx, ty, _heading, tvx, tvy = target_at(segment, target_speed, t)
                obstacle_positions_at(obstacle_start, obstacle_velocity, t, positions)
                plan_step(a, memory, ring, plan_out, t, odom_x, odom_y, odom_yaw, odom_velocity, tx, ty, tvx, tvy,
                          positions, obstacle_velocity, radii, distances)
                next_v = plan_out[Q_V]
                next_w = plan_out[Q_OMEGA]
                new_plan = True
                stuck_at_end = plan_out[Q_MODE] == STUCK
                if stuck_at_end:
                    stuck_steps += 1
                final_distance = plan_out[Q_DISTANCE]
                for j in range(radii.shape[0]):
                    inside = distances[j] <= a[A_RHO_O]
                    if inside and not detected[j]:
                        detected_at[j, 0] = t
                        detected_at[j, 1] = x
                        detected_at[j, 2] = y
                        detected_at[j, 3] = state[S_PSI]
                        detected_at[j, 4] = state[S_XD]
                        detected_at[j, 5] = state[S_PSID]
                    detected[j] = inside
        else:
            v_ref, w_ref = command_profile_at(cmd_times, cmd_speeds, cmd_yaw_rates, t)
            command_stamp = t  # a command profile: a command at every sample
        hold = estimate and estimator_m[E_CALIBRATING] != 0.0
        cascade_compute(c, control, control_out, t, v_ref, w_ref, velocity, yaw_rate, pitch, pitch_rate,
                        not commanded, hold, command_stamp)
        true_pitch = state[S_TH]
        pitch_min = min(pitch_min, true_pitch)
        pitch_max = max(pitch_max, true_pitch)
        if t >= SETTLING_TIME:
            pitch_settled = max(pitch_settled, abs(true_pitch))
        if record:
            row = trace[k]
            row[T_T] = t
            row[T_X_C] = x
            row[T_Y_C] = y
            row[T_PITCH] = pitch  # what the controller used
            row[T_VELOCITY] = velocity
            row[T_YAW] = state[S_PSI]
            row[T_LEFT_TORQUE] = control_out[O_LEFT]
            row[T_RIGHT_TORQUE] = control_out[O_RIGHT]
            row[T_VELOCITY_REF] = control_out[O_VELOCITY_REF]
            row[T_YAW_RATE_REF] = control_out[O_YAW_RATE_REF]
            row[T_PITCH_TRUE] = true_pitch
            row[T_VELOCITY_TRUE] = state[S_XD]
        if has_target:  # the controller takes a cmd_vel from the first state stamped after it
            v_ref = next_v
            w_ref = next_w
            if new_plan:
                command_stamp = (step_count + steps_per_control) * h
                new_plan = False
                commanded = True
        if k == n_samples - 1 or fallen or (end_on_target and not math.isnan(reached_at)):
            break
        left = min(max(control_out[O_LEFT], -torque_limit), torque_limit)  # the motor driver's limit
        right = min(max(control_out[O_RIGHT], -torque_limit), torque_limit)
        fallen = advance_upright(p, state, left, right, h, steps_per_control, work)
        step_count += steps_per_control
        if has_target and not advance_segments(segment, draws, step_count * h, target_speed, turn_interval):
            raise ValueError("batch: the target's yaw-rate draws ran out (size them with draws_needed)")
    result[Z_REACHED_AT] = reached_at
    result[Z_COLLISIONS] = tally[W_COLLISIONS]
    result[Z_MIN_CLEARANCE] = min_clearance
    result[Z_PITCH_MIN] = pitch_min
    result[Z_PITCH_MAX] = pitch_max
    result[Z_FALLEN] = 1.0 if fallen else 0.0
    result[Z_STUCK_STEPS] = stuck_steps
    result[Z_SIM_TIME] = t
    result[Z_SAMPLES] = k + 1
    result[Z_PHYSICS_STEPS] = step_count
    result[Z_HIT_OBSTACLE] = hit_obstacle
    result[Z_DETECTED:Z_DETECTED + 6] = hit_detected
    result[Z_PITCH_SETTLED] = pitch_settled
    result[Z_FINAL_DISTANCE] = final_distance
    result[Z_STUCK_AT_END] = 1.0 if stuck_at_end else 0.0
    result[Z_LIFT_EVENTS] = lift_events
    result[Z_SLIP_EVENTS] = slip_events
    result[Z_LIFTED_TIME] = lifted_samples * steps_per_control * h
    result[Z_SLIPPING_TIME] = slipping_samples * steps_per_control * h
    result[Z_PITCH_ERROR_SQUARES] = pitch_error_squares


@parallel_kernel
def _run_robots(params, states, c, a, run, segments, draws, obstacle_start, obstacle_velocity, radii, profile,
                results, traces, imu_c, imu_m, generators, encoder_c, encoder_m, estimator_q):
    record = traces.shape[0] > 0
    for i in prange(params.shape[0]):
        trace = traces[i] if record else traces[0]  # (0, N_TRACE): nothing recorded
        run_robot(params[i], states[i], c, a, run, segments[i], draws[i], obstacle_start[i], obstacle_velocity[i],
                  radii, profile, results[i], trace, imu_c, imu_m[i], generators[i], encoder_c, encoder_m[i],
                  estimator_q)


@dataclass
class BatchResult:
    """Per-robot outcomes (Z_* columns of `table`) and, when recorded, per-sample traces."""

    table: np.ndarray  # (N, N_RESULT)
    traces: np.ndarray | None  # (N, samples, N_TRACE); rows past a robot's own sample count are unused
    physics_rate: float

    @property
    def robot_steps(self) -> int:
        """Physics steps taken over all robots."""
        return int(self.table[:, Z_PHYSICS_STEPS].sum())

    def trace(self, robot: int) -> dict[str, np.ndarray]:
        """One robot's recorded samples by column name."""
        if self.traces is None:
            raise ValueError("the batch was run without record=True")
        n = int(self.table[robot, Z_SAMPLES])
        return {name: self.traces[robot, :n, j] for j, name in enumerate(TRACE_COLUMNS)}


def run_batch(
    scenario: Scenario,
    seeds: Sequence[int],
    params: np.ndarray,
    control: Mapping[str, Any] | None = None,
    planner: Mapping[str, Any] | None = None,
    physics_rate: float = PHYSICS_RATE,
    planner_rate: float = PLANNER_RATE,
    world_rate: float = WORLD_RATE,
    duration: float | None = None,
    record: bool = False,
    sim: Mapping[str, Any] | None = None,
) -> BatchResult:
    """Run len(seeds) robots of `scenario`; robot i has the parameter vector params[i] (robot_params) and
    the world (and sensor noise) of seeds[i]. Settings default to the parameter tables (the planner's under
    what the scenario pins; `sim`: the simulator's sensor and traction parameters, imu.*, encoder.*,
    traction.*); `duration` to the scenario's."""
    n = len(seeds)
    params = np.ascontiguousarray(params, dtype=float)
    if n < 1 or params.shape[0] != n:
        raise ConfigError(f"batch: {n} seeds and {params.shape[0]} parameter rows: need as many, at least 1")
    control_cfg = resolve_controller(control)
    planner_cfg = resolve_planner(planner, scenario)
    rate = control_cfg["rate"]
    steps_per_control = steps_per_publish(physics_rate, rate)
    duration = scenario.duration if duration is None else duration
    n_samples = round(duration * rate) + 1

    sc = scenario
    start = initial_state(sc.start_x, sc.start_y, sc.start_yaw, sc.start_pitch)
    states = np.tile(start, (n, 1))
    layouts = [vary(sc, seed) for seed in seeds]  # each seed's layout, as its World would build it
    tgt = sc.target
    segments = np.zeros((n, N_SEGMENT))
    if tgt is not None:
        count = draws_needed(duration, tgt.turn_interval)
        draws = np.stack([yaw_rate_draws(np.random.default_rng(seed), tgt.max_yaw_rate, count) for seed in seeds])
        segments[:, [SEG_X, SEG_Y, SEG_HEADING]] = [(s.target.x, s.target.y, s.target.heading) for s in layouts]
        segments[:, SEG_YAW_RATE] = draws[:, 0]
        segments[:, SEG_NEXT_DRAW] = 1
    else:
        draws = np.zeros((n, 1))
    m = len(sc.obstacles)
    obstacle_start = np.array([[[o.x, o.y] for o in s.obstacles] for s in layouts], dtype=float).reshape(n, m, 2)
    obstacle_velocity = np.array([[[o.vx, o.vy] for o in s.obstacles] for s in layouts],
                                 dtype=float).reshape(n, m, 2)
    radii = np.array([o.radius for o in sc.obstacles], dtype=float)
    profile = np.ascontiguousarray(np.stack(command_profile(sc)))
    run = RUN_LAYOUT.pack({
        "h": 1.0 / physics_rate, "steps_per_control": steps_per_control, "n_samples": n_samples,
        "planner_period": 1.0 / planner_rate, "world_period": 1.0 / world_rate, "has_target": tgt is not None,
        "end_on_target": sc.end_on_target, "target_speed": tgt.speed if tgt else 0.0,
        "turn_interval": tgt.turn_interval if tgt else 1.0, "capture_radius": tgt.capture_radius if tgt else 0.0,
        "ring_rows": progress_capacity(planner_cfg["stuck_time"], planner_rate),
        "sensors": 0.0, "estimate": 0.0, "friction": 0.0,
    })
    sim_cfg = validate_all(SENSOR_SPECS, {**defaults(SENSOR_SPECS), **(sim or {})})
    imu_c = imu_vector(sim_cfg, rate)
    encoder_c = encoder_vector(sim_cfg, rate)
    raw = bool(sim_cfg["imu.raw"])
    ideal = not raw and not imu_c[1:].any() and encoder_c[0] == 0.0
    estimate = uses_estimator(control_cfg["pitch_source"], raw)
    imu_m = np.tile(new_imu_memory(imu_c), (n, 1))
    encoder_m = np.tile(new_encoder_memory(encoder_c), (n, 1))
    generators = np.stack([new_generator(seed, IMU_STREAM) for seed in seeds])
    run[U_SENSORS] = 0.0 if ideal and not estimate else 1.0
    run[U_ESTIMATE] = 1.0 if estimate else 0.0
    run[U_FRICTION] = sim_cfg["traction.friction"]
    results = np.zeros((n, N_RESULT))
    traces = np.zeros((n, n_samples, N_TRACE)) if record else np.zeros((1, 0, N_TRACE))
    with parallel_chunksize(4):  # runs end at different times: hand robots out in small chunks
        _run_robots(params, states, control_vector(control_cfg), planner_vector(planner_cfg), run, segments, draws,
                    obstacle_start, obstacle_velocity, radii, profile, results, traces, imu_c, imu_m, generators,
                    encoder_c, encoder_m, estimator_vector(control_cfg))
    return BatchResult(results, traces if record else None, physics_rate)
