"""Batch engine: N robots at once through dynamics, motors, controller, planner and world, without ROS.

Each robot is the headless closed loop of `closed_loop` (the state at step k, the command computed from
it held until step k+1; the planner and the world's assessment at their own rates). All robots advance
sample by sample: their samples in parallel threads, then their physics in groups of robots stepped
together in lanes (structure of arrays, vectorised over the robots). It calls the very kernels the scalar
cores and so the nodes call (`dynamics.advance_upright(_lanes)`, `cascade.cascade_compute`, `planner.plan_step`, the world's
`advance_segments`, `target_at`, the agents' `agents_advance` and `agents_at`, `assess_obstacles`, the scenario's
`command_profile_at`): there is no second copy of an equation to drift apart.

Like the headless closed loop, the batch exchanges every command (lockstep, no lost or stale message) and
reads an ideal IMU (no noise, no bias) unless sensors are set. A robot's run ends on its target
(end_on_target), its fall, or the scenario's duration; finished robots leave the groups and cost nothing
while the others run on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twbr_common.jit import (
    get_num_threads,
    inline_kernel,
    kernel,
    lane_kernel,
    parallel_chunksize,
    parallel_kernel,
    prange,
)
from twbr_common.layout import Layout
from twbr_common.params import ConfigError, default_of, defaults, validate_all
from twbr_common.timing import is_due, next_due, takes_effect
from twbr_common.wire import (
    detection_read_back,
    heading_speed,
    pitch_yaw_read_back,
    stamp_seconds_of,
    step_nanoseconds,
    target_velocity_read_back,
)
from twbr_control.cascade import K_ENABLED, O_LEFT, O_RIGHT, O_VELOCITY_REF, O_YAW_RATE_REF, cascade_compute
from twbr_control.cascade import N_OUTPUTS as N_CONTROL_OUTPUTS
from twbr_control.cascade import N_STATE as N_CONTROL_STATE
from twbr_control.cascade import settings_vector as control_vector
from twbr_control.collision_monitor import allowed_speed
from twbr_control.controller_params import resolve as resolve_controller
from twbr_control.estimator import E_CALIBRATING, E_PITCH, E_PITCH_RATE, E_VELOCITY_ESTIMATE, estimator_update, uses_estimator
from twbr_control.estimator import N_MEMORY as N_ESTIMATOR_MEMORY
from twbr_control.estimator import settings_vector as estimator_vector
from twbr_planner.apf import (
    A_RHO_O,
    A_ROBOT_RADIUS,
    PROGRESS_COLUMNS,
    Q_DISTANCE,
    Q_MODE,
    Q_OMEGA,
    Q_V,
    STUCK,
    clearances,
    progress_capacity,
)
from twbr_planner.apf import N_MEMORY as N_PLANNER_MEMORY
from twbr_planner.apf import N_OUTPUTS as N_PLANNER_OUTPUTS
from twbr_planner.apf import settings_vector as planner_vector
from twbr_planner.planner import plan_step
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
from twbr_planner.planner_params import resolve as resolve_planner
from twbr_sim import lidar
from twbr_sim.agents import N_AGENT_STATE, agent_arrays, agents_advance, agents_at, agents_begin, stepped
from twbr_sim.dynamics import (
    LANES,
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
    advance_upright_lanes,
    derivatives,
    initial_state,
    lane_derivatives,
    lane_group,
    robot_substeps,
    shared_substeps,
)
from twbr_sim.encoders import J_VELOCITY, J_X, J_Y, J_YAW, J_YAW_RATE, encoder_sample
from twbr_sim.encoders import N_OUTPUTS as N_ENCODER_OUTPUTS
from twbr_sim.encoders import new_memory as new_encoder_memory
from twbr_sim.encoders import settings_vector as encoder_vector
from twbr_sim.imu import IMU_STREAM, N_READING, RD_ACCEL, RD_GYRO, RD_PITCH, RD_ROLL, RD_YAW, imu_init, imu_sample
from twbr_sim.imu import new_memory as new_imu_memory
from twbr_sim.imu import settings_vector as imu_vector
from twbr_sim.noise import new_generator
from twbr_sim.robot_params import P_R, P_ROBOT_RADIUS, wheel_torque_limit
from twbr_sim.scenario import Scenario, command_profile, command_profile_at, vary
from twbr_sim.simulator import SENSOR_SPECS, SIM_SPECS, steps_per_publish
from twbr_sim.target_sensor import TARGET_SENSOR_STREAM, measure_target
from twbr_sim.target_sensor import settings_vector as look_vector
from twbr_sim.traction import N_OUTPUTS as N_TRACTION_OUTPUTS
from twbr_sim.traction import lane_wheel_loads, traction_flags, wheel_loads
from twbr_sim.world import (
    N_SEGMENT,
    N_TALLY,
    SEG_HEADING,
    SEG_NEXT_DRAW,
    SEG_T,
    SEG_X,
    SEG_Y,
    SEG_YAW_RATE,
    W_COLLISIONS,
    advance_segments,
    assess_obstacles,
    draws_needed,
    target_at,
    yaw_rate_draws,
)
from twbr_tracker.detection import N_DISC
from twbr_tracker.detection import settings_vector as detection_vector
from twbr_tracker.evaluation import GATE, N_JUDGE, SETTLE, judge_lists
from twbr_tracker.surfaces import REF_BINS
from twbr_tracker.surfaces import settings_vector as surface_vector
from twbr_tracker.target import (
    MISSION_PRIOR_STD,
    N_ESTIMATE,
    TARGET_SPECS,
    TG_PRIOR_STD,
    TG_PRIOR_X,
    TG_PRIOR_Y,
    target_begin,
    target_estimate,
    target_measure,
)
from twbr_tracker.target import N_MEMORY as N_TARGET_MEMORY
from twbr_tracker.target import settings_vector as target_vector
from twbr_tracker.tracker import K_NEXT_ID, N_COUNTERS, N_OBSTACLE_ROW, TRACKER_SPECS, output_rows, tracker_scan
from twbr_tracker.tracks import N_TRACK, TS_MAX_TRACKS
from twbr_tracker.tracks import settings_vector as track_vector
from twbr_tracker.wall_memory import N_WALL, WM_MAX_DISCS
from twbr_tracker.wall_memory import settings_vector as wall_vector

WORLD_RATE = default_of(SIM_SPECS, "world_rate")  # [Hz] collisions and clearance are sampled at it
PLANNER_RATE = default_of(PLANNER_NODE_SPECS, "rate")  # [Hz]
PHYSICS_RATE = default_of(SIM_SPECS, "physics_rate")  # [Hz]

# What every robot of a batch shares besides the controller's and planner's settings: the step [s], the
# control period in physics steps, the samples of a run, the planner's and world's periods [s], whether
# there is a target and the run ends on it, the target's speed [m/s], turn interval [s] and capture
# radius [m], and the rows of the planner's progress ring.
RUN_LAYOUT = Layout((
    "h", "step_ns", "steps_per_control", "n_samples", "planner_period", "world_period", "has_target", "end_on_target",
    "target_speed", "turn_interval", "capture_radius", "ring_rows", "sensors", "estimate", "friction",
    "monitor", "footprint", "stop_margin", "deceleration", "reaction_time", "agents_stepped", "lidar",
    "scan_period", "look_period", "axle_height", "lidar_height", "scan_angle_min", "scan_angle_increment",
    "scan_time_increment",
))
U_H = RUN_LAYOUT["h"]
U_STEP_NS = RUN_LAYOUT["step_ns"]  # a physics step [ns], as the stamps count it
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
U_MONITOR = RUN_LAYOUT["monitor"]  # the controller's collision monitor (collision_monitor.*) is on
U_FOOTPRINT = RUN_LAYOUT["footprint"]
U_STOP_MARGIN = RUN_LAYOUT["stop_margin"]
U_DECELERATION = RUN_LAYOUT["deceleration"]
U_REACTION_TIME = RUN_LAYOUT["reaction_time"]
U_AGENTS_STEPPED = RUN_LAYOUT["agents_stepped"]  # an obstacle moves other than on a fixed line (twbr_sim.agents)
# Perception "lidar": the planner and the collision monitor on tracker_scan's obstacles from the simulated
# scan, every scan_period [s], and the planner on the fused target from the detector's looks, every
# look_period [s] (0: no detector, the world's target); the tracker's placing of the scanner (axle and
# scanner heights [m]) and the scan's angle fields as a LaserScan carries them (float32) [rad, s].
U_LIDAR = RUN_LAYOUT["lidar"]
U_SCAN_PERIOD = RUN_LAYOUT["scan_period"]
U_LOOK_PERIOD = RUN_LAYOUT["look_period"]
U_AXLE_HEIGHT = RUN_LAYOUT["axle_height"]
U_LIDAR_HEIGHT = RUN_LAYOUT["lidar_height"]
U_SCAN_ANGLE_MIN = RUN_LAYOUT["scan_angle_min"]
U_SCAN_ANGLE_INCREMENT = RUN_LAYOUT["scan_angle_increment"]
U_SCAN_TIME_INCREMENT = RUN_LAYOUT["scan_time_increment"]
# Per-robot result columns.
# The first collision's obstacle (-1: none) and where the robot was when that obstacle last came into the
# detection range (t [s], x, y [m], yaw [rad], speed [m/s], yaw rate [rad/s]), for the avoidability check;
# the pitch's largest magnitude after the first 2 s; the distance to the target and whether the planner
# reported stuck at the last plan.
RESULT_LAYOUT = Layout((
    "reached_at", "collisions", "min_clearance", "pitch_min", "pitch_max", "fallen", "stuck_steps", "sim_time",
    "samples", "physics_steps", "hit_obstacle", ("detected", 6), "pitch_abs_max_settled", "final_distance",
    "stuck_at_end", "lift_events", "slip_events", "lifted_time", "slipping_time", "pitch_error_square_sum",
    "collision_limited", "torque_step_max", ("tracking", N_JUDGE),
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
Z_COLLISION_LIMITED = RESULT_LAYOUT["collision_limited"]  # samples whose command the collision monitor lowered
Z_LIFTED_TIME = RESULT_LAYOUT["lifted_time"]  # [s]
Z_SLIPPING_TIME = RESULT_LAYOUT["slipping_time"]  # [s]
Z_PITCH_ERROR_SQUARES = RESULT_LAYOUT["pitch_error_square_sum"]  # sum over samples of (pitch used - true)^2
Z_TORQUE_STEP_MAX = RESULT_LAYOUT["torque_step_max"]  # [N·m] largest change of a wheel's torque between two samples
Z_TRACKING = RESULT_LAYOUT["tracking"]  # with the LiDAR: the tracker judged at every scan (evaluation.JUDGE_LAYOUT)
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


# What a robot's run carries from one sample to the next besides its result row (RESULT_LAYOUT: the running
# tallies, and the physics steps, which give the sample index): the wheel torques being applied [N*m], the
# traction flags and their sample counts, the world's and the planner's next due times [s], the references in effect and
# the planner's next ones [m/s, rad/s], the stamp from which they apply [s], whether a plan is new and
# whether any command has arrived, and whether the physics left the state's derivative and wheel loads for
# the sample (computed there in lanes, vectorised; else by the sample itself).
LOOP_LAYOUT = Layout((
    "left", "right", "lifted", "slipping", "lifted_samples", "slipping_samples", "world_next", "plan_next",
    "v_ref", "w_ref", "next_v", "next_w", "command_stamp", "new_plan", "plan_stamp", "commanded", "derived",
    "world_t", "agent_steps", "scan_next", "look_next", "seen_t", "seen_count", "target_known", "target_x",
    "target_y", "target_vx", "target_vy",
))
L_LEFT = LOOP_LAYOUT["left"]
L_RIGHT = LOOP_LAYOUT["right"]
L_LIFTED = LOOP_LAYOUT["lifted"]
L_SLIPPING = LOOP_LAYOUT["slipping"]
L_LIFTED_SAMPLES = LOOP_LAYOUT["lifted_samples"]
L_SLIPPING_SAMPLES = LOOP_LAYOUT["slipping_samples"]
L_WORLD_NEXT = LOOP_LAYOUT["world_next"]
L_PLAN_NEXT = LOOP_LAYOUT["plan_next"]
L_V_REF = LOOP_LAYOUT["v_ref"]
L_W_REF = LOOP_LAYOUT["w_ref"]
L_NEXT_V = LOOP_LAYOUT["next_v"]
L_NEXT_W = LOOP_LAYOUT["next_w"]
L_COMMAND_STAMP = LOOP_LAYOUT["command_stamp"]
L_NEW_PLAN = LOOP_LAYOUT["new_plan"]
L_PLAN_STAMP = LOOP_LAYOUT["plan_stamp"]  # [s] the instant the pending plan (next_v, next_w) was made
L_COMMANDED = LOOP_LAYOUT["commanded"]
L_DERIVED = LOOP_LAYOUT["derived"]
L_WORLD_T = LOOP_LAYOUT["world_t"]  # the last world instant: positions[j] are the obstacles then [s]
L_AGENT_STEPS = LOOP_LAYOUT["agent_steps"]  # the agents' steps done (agents.agents_advance)
L_SCAN_NEXT = LOOP_LAYOUT["scan_next"]  # [s] the next scan's instant
L_LOOK_NEXT = LOOP_LAYOUT["look_next"]  # [s] the target detector's next look
L_SEEN_T = LOOP_LAYOUT["seen_t"]  # [s] the last scan's instant: the seen_* arrays are the obstacles then
L_SEEN_COUNT = LOOP_LAYOUT["seen_count"]  # obstacles the last scan gave
L_TARGET_KNOWN = LOOP_LAYOUT["target_known"]  # the fused target at the last look (1: known) [m, m/s]
L_TARGET_X = LOOP_LAYOUT["target_x"]
L_TARGET_Y = LOOP_LAYOUT["target_y"]
L_TARGET_VX = LOOP_LAYOUT["target_vx"]
L_TARGET_VY = LOOP_LAYOUT["target_vy"]
N_LOOP = len(LOOP_LAYOUT)


# Per-robot memories of a batch (rows by robot), one array each, in a tuple read by these names' indices
# (a named tuple cannot cross into a parallel loop's body in numba): MA_LOOP is LOOP_LAYOUT; the cascade's
# state and outputs; the planner's memory, progress ring and outputs; the world's tally; the obstacles'
# positions [m] at the last world instant and distances [m]; whether each obstacle is in range and the robot's
# state when it came in; the state's derivative, the IMU reading, odom, wheel loads; the estimator's
# memory, the agents' states and the obstacles' velocities [m/s]; with the LiDAR the tracker's tracks,
# covariances and counters, the obstacles it gave at the last scan (positions, velocities [m, m/s] and
# radii), those moved to a plan's instant and their clearances, and the fused target's filter.
MEMORY_ARRAYS_LAYOUT = Layout((
    "loop", "control", "control_out", "planner_memory", "ring", "plan_out", "tally", "positions", "distances",
    "detected", "detected_at", "derivative", "reading", "odometry", "loads", "estimator_memory",
    "agent_state", "velocities", "tracks", "track_cov", "track_counters", "seen_positions", "seen_velocities",
    "seen_radii", "plan_positions", "seen_distances", "target_memory", "target_cov", "walls", "track_born",
    "track_judged", "surfaces",
))
MA_LOOP = MEMORY_ARRAYS_LAYOUT["loop"]
MA_CONTROL = MEMORY_ARRAYS_LAYOUT["control"]
MA_CONTROL_OUT = MEMORY_ARRAYS_LAYOUT["control_out"]
MA_PLANNER_MEMORY = MEMORY_ARRAYS_LAYOUT["planner_memory"]
MA_RING = MEMORY_ARRAYS_LAYOUT["ring"]
MA_PLAN_OUT = MEMORY_ARRAYS_LAYOUT["plan_out"]
MA_TALLY = MEMORY_ARRAYS_LAYOUT["tally"]
MA_POSITIONS = MEMORY_ARRAYS_LAYOUT["positions"]
MA_DISTANCES = MEMORY_ARRAYS_LAYOUT["distances"]
MA_DETECTED = MEMORY_ARRAYS_LAYOUT["detected"]
MA_DETECTED_AT = MEMORY_ARRAYS_LAYOUT["detected_at"]
MA_DERIVATIVE = MEMORY_ARRAYS_LAYOUT["derivative"]
MA_READING = MEMORY_ARRAYS_LAYOUT["reading"]
MA_ODOMETRY = MEMORY_ARRAYS_LAYOUT["odometry"]
MA_LOADS = MEMORY_ARRAYS_LAYOUT["loads"]
MA_ESTIMATOR_MEMORY = MEMORY_ARRAYS_LAYOUT["estimator_memory"]
MA_AGENT_STATE = MEMORY_ARRAYS_LAYOUT["agent_state"]
MA_VELOCITIES = MEMORY_ARRAYS_LAYOUT["velocities"]
MA_TRACKS = MEMORY_ARRAYS_LAYOUT["tracks"]
MA_TRACK_COV = MEMORY_ARRAYS_LAYOUT["track_cov"]
MA_TRACK_COUNTERS = MEMORY_ARRAYS_LAYOUT["track_counters"]
MA_SEEN_POSITIONS = MEMORY_ARRAYS_LAYOUT["seen_positions"]
MA_SEEN_VELOCITIES = MEMORY_ARRAYS_LAYOUT["seen_velocities"]
MA_SEEN_RADII = MEMORY_ARRAYS_LAYOUT["seen_radii"]
MA_PLAN_POSITIONS = MEMORY_ARRAYS_LAYOUT["plan_positions"]
MA_SEEN_DISTANCES = MEMORY_ARRAYS_LAYOUT["seen_distances"]
MA_TARGET_MEMORY = MEMORY_ARRAYS_LAYOUT["target_memory"]
MA_TARGET_COV = MEMORY_ARRAYS_LAYOUT["target_cov"]
MA_WALLS = MEMORY_ARRAYS_LAYOUT["walls"]
MA_TRACK_BORN = MEMORY_ARRAYS_LAYOUT["track_born"]  # the listed tracks' ids and first listing (judge_lists)
MA_TRACK_JUDGED = MEMORY_ARRAYS_LAYOUT["track_judged"]  # per obstacle: the track it was last matched to
MA_SURFACES = MEMORY_ARRAYS_LAYOUT["surfaces"]  # the tracker's earlier scans (twbr_tracker.surfaces)
# What a sample reads of the world (a tuple in this order): each robot's target segment, the obstacles'
# motions (agents.AGENT_LAYOUT) and waypoints [m], their radii [m], and the command profile (rows t [s],
# v [m/s], omega [rad/s]); and of the sensors: their settings, each robot's sensor memories and generator,
# and the estimator's settings.
WORLD_ARRAYS = ("segments", "agents", "waypoints", "radii", "profile")
SENSOR_ARRAYS = ("imu_c", "imu_m", "generators", "encoder_c", "encoder_m", "estimator_q")
# And of perception: the scanner's settings (twbr_sim.lidar) and each robot's generator, the detector's
# (target_sensor) likewise, the tracker's detection, tracking, wall memory and surface settings, and each
# robot's target filter settings (its prior: the robot's own layout's target start).
PERCEPTION_ARRAYS = ("lidar_s", "lidar_generators", "look_s", "look_generators", "detection_d", "tracking_k",
                     "walls_w", "surfaces_u", "target_s")


@kernel
def new_memories(n, run, n_obstacles, n_tracks, n_seen, n_walls):
    """Per-robot memories for n robots of a run, in MEMORY_ARRAYS_LAYOUT's order (the agents' states:
    agents.AGENT_STATE_LAYOUT; n_tracks, n_seen, n_walls: the tracker's table, output rows and wall memory, 0
    without LiDAR)."""
    n_judged = n_obstacles if n_tracks > 0 else 0  # the judge's memory of each obstacle's last track
    return (  # noqa: RUF005 (numba types no unpacking into a literal)
        np.zeros((n, N_LOOP)), np.zeros((n, N_CONTROL_STATE)), np.zeros((n, N_CONTROL_OUTPUTS)),
        np.zeros((n, N_PLANNER_MEMORY)), np.zeros((n, int(run[U_RING_ROWS]), PROGRESS_COLUMNS)),
        np.zeros((n, N_PLANNER_OUTPUTS)), np.zeros((n, N_TALLY)), np.zeros((n, n_obstacles, 2)),
        np.zeros((n, n_obstacles)), np.zeros((n, n_obstacles), dtype=np.bool_), np.zeros((n, n_obstacles, 6)),
        np.zeros((n, N_STATE)), np.zeros((n, N_READING)), np.zeros((n, N_ENCODER_OUTPUTS)),
        np.zeros((n, N_TRACTION_OUTPUTS)), np.zeros((n, N_ESTIMATOR_MEMORY)),
    ) + (  # two tuples: Python builds a literal of more than 30 items through a list, which numba cannot type
        np.zeros((n, n_obstacles, N_AGENT_STATE)), np.zeros((n, n_obstacles, 2)),
        np.zeros((n, n_tracks, N_TRACK)), np.zeros((n, n_tracks, 4, 4)), np.zeros((n, N_COUNTERS)),
        np.zeros((n, n_seen, 2)), np.zeros((n, n_seen, 2)), np.zeros((n, n_seen)), np.zeros((n, n_seen, 2)),
        np.zeros((n, n_seen)), np.zeros((n, N_TARGET_MEMORY)), np.zeros((n, 4, 4)), np.zeros((n, n_walls, N_WALL)),
        np.zeros((n, n_tracks, 2)), np.zeros((n, n_judged)),
        np.full((n, 2, REF_BINS + 1 if n_tracks > 0 else 0, 3), np.nan),
    )


@kernel
def robot_begin(j, run, result, memories, imu_c, imu_m, generator, agents):
    """Set robot j of `memories` to the start of a run (its result row holds the running tallies)."""
    loop, control = memories[MA_LOOP], memories[MA_CONTROL]
    agents_begin(agents, memories[MA_AGENT_STATE][j])
    loop[j, :] = 0.0
    loop[j, L_WORLD_NEXT] = -math.inf
    loop[j, L_PLAN_NEXT] = -math.inf
    loop[j, L_SCAN_NEXT] = -math.inf
    loop[j, L_LOOK_NEXT] = -math.inf
    memories[MA_TRACKS][j] = 0.0
    memories[MA_TRACK_COV][j] = 0.0
    memories[MA_TRACK_COUNTERS][j, :] = 0.0
    memories[MA_TRACK_COUNTERS][j, K_NEXT_ID] = 1.0
    memories[MA_TRACK_BORN][j, :, 0] = -1.0
    memories[MA_TRACK_JUDGED][j, :] = -1.0
    target_begin(memories[MA_TARGET_MEMORY][j], memories[MA_TARGET_COV][j])
    loop[j, L_COMMANDED] = 0.0 if run[U_HAS_TARGET] != 0.0 else 1.0  # a planner's first command applies
    control[j, :] = 0.0                                                # from the second sample
    control[j, K_ENABLED] = 1.0
    memories[MA_PLANNER_MEMORY][j, :] = 0.0
    memories[MA_RING][j] = 0.0
    memories[MA_TALLY][j, :] = 0.0
    memories[MA_DETECTED][j, :] = False
    memories[MA_DETECTED_AT][j] = 0.0
    memories[MA_ESTIMATOR_MEMORY][j, :] = 0.0
    result[:] = 0.0
    result[Z_REACHED_AT] = math.nan
    result[Z_MIN_CLEARANCE] = math.inf
    result[Z_PITCH_MIN] = math.inf
    result[Z_PITCH_MAX] = -math.inf
    result[Z_HIT_OBSTACLE] = -1.0
    result[Z_DETECTED:Z_DETECTED + 6] = math.nan
    result[Z_FINAL_DISTANCE] = math.nan
    if run[U_SENSORS] != 0.0:
        imu_init(imu_c, imu_m, generator)


@inline_kernel
def reads_derivative(run):
    """Whether a sample reads the state's derivative: for the sensors' models or the traction tally."""
    return run[U_SENSORS] != 0.0 or run[U_FRICTION] > 0.0


@kernel
def robots_moved(run, results, segments, draws, running, lo, size, fell):
    """Book the physics of robots running[lo:lo + size] since their last sample (steps_per_control steps;
    fell[j]: robot running[lo + j] fell in them) and move their targets on. One call per group: a call
    takes and drops a reference count on each array it is passed."""
    for j in range(size):
        i = running[lo + j]
        results[i, Z_PHYSICS_STEPS] += run[U_STEPS_PER_CONTROL]
        if fell[j]:
            results[i, Z_FALLEN] = 1.0
        t = results[i, Z_PHYSICS_STEPS] * run[U_H]
        if (run[U_HAS_TARGET] != 0.0 and t >= segments[i, SEG_T] + run[U_TURN_INTERVAL]  # a turn is due
                and not advance_segments(segments[i], draws[i], t, run[U_TARGET_SPEED], run[U_TURN_INTERVAL])):
            raise ValueError("batch: the target's yaw-rate draws ran out (size them with draws_needed)")


@inline_kernel
def robot_end(run, results, memories, j):
    """Robot j's result row from its tallies."""
    loop, tally = memories[MA_LOOP], memories[MA_TALLY]
    sample_time = run[U_STEPS_PER_CONTROL] * run[U_H]
    results[j, Z_COLLISIONS] = tally[j, W_COLLISIONS]
    results[j, Z_LIFTED_TIME] = loop[j, L_LIFTED_SAMPLES] * sample_time
    results[j, Z_SLIPPING_TIME] = loop[j, L_SLIPPING_SAMPLES] * sample_time


@lane_kernel
def derive_lanes(p, s, left, right, ds, loads, lanes, friction):
    """The derivative of lanes 0..lanes-1 under their commands (as the sample would compute it) and, with
    friction, their wheel loads: the same equations as the sample's, in loops over the robots."""
    for i in range(lanes):
        lane_derivatives(p, i, s, left[i], right[i], ds)
    if friction > 0.0:
        for i in range(lanes):
            lane_wheel_loads(p, i, s, ds, loads)


@inline_kernel
def from_lanes(lanes, rows, running, lo, size):
    """Lane j of a group (lanes[:, j]) into row running[lo + j] of a per-robot array, for j < size."""
    for j in range(size):
        i = running[lo + j]
        for k in range(lanes.shape[0]):
            rows[i, k] = lanes[k, j]


SERIAL_ROBOTS = 8  # at most this many running robots are stepped in one thread, one by one


@kernel
def _samples(running, lo, hi, ended, params, states, c, a, run, world, sensors, perception, results, traces,
             torque_limits, memories):
    """The samples of robots running[lo:hi], each as run_closed_loop's: sense the state, assess the world,
    plan, control. ended[q]: robot running[q]'s run ends there, its result then complete; else the torques
    to apply until its next sample are in loop[j].

    One call per share of robots (a thread's), the robots' loop in it. Its arrays are indexed by robot
    (states[j, S_TH]), not through row views or an inlined function's parameters: numba takes and drops a
    reference count for each, an atomic operation on a counter the two threads share. Rows are taken only
    for the calls that want one (the planner and the world at their rates, the sensors' models, the
    controller); the controller's settings are this call's copy."""
    loop, control, control_out = memories[MA_LOOP], memories[MA_CONTROL], memories[MA_CONTROL_OUT]
    memory, ring, plan_out = memories[MA_PLANNER_MEMORY], memories[MA_RING], memories[MA_PLAN_OUT]
    tally, positions, distances = memories[MA_TALLY], memories[MA_POSITIONS], memories[MA_DISTANCES]
    velocities, agent_state = memories[MA_VELOCITIES], memories[MA_AGENT_STATE]
    detected, detected_at = memories[MA_DETECTED], memories[MA_DETECTED_AT]
    derivative, reading = memories[MA_DERIVATIVE], memories[MA_READING]
    odometry, loads = memories[MA_ODOMETRY], memories[MA_LOADS]
    estimator_m = memories[MA_ESTIMATOR_MEMORY]
    tracks, track_cov, track_counters = memories[MA_TRACKS], memories[MA_TRACK_COV], memories[MA_TRACK_COUNTERS]
    seen_positions, seen_velocities = memories[MA_SEEN_POSITIONS], memories[MA_SEEN_VELOCITIES]
    seen_radii, plan_positions = memories[MA_SEEN_RADII], memories[MA_PLAN_POSITIONS]
    seen_distances = memories[MA_SEEN_DISTANCES]
    target_memory, target_cov = memories[MA_TARGET_MEMORY], memories[MA_TARGET_COV]
    track_born, track_judged = memories[MA_TRACK_BORN], memories[MA_TRACK_JUDGED]
    walls, surfaces = memories[MA_WALLS], memories[MA_SURFACES]
    segments, agents, waypoints, radii, profile = world  # WORLD_ARRAYS
    imu_c, imu_m, generators, encoder_c, encoder_m, estimator_q = sensors  # SENSOR_ARRAYS
    lidar_s, lidar_generators, look_s, look_generators, detection_d, tracking_k, walls_w, surfaces_u, target_s = (
        perception)
    lidar_on = run[U_LIDAR] != 0.0
    looks = lidar_on and run[U_LOOK_PERIOD] > 0.0  # the planner follows the fused target
    # this call's scratch: a scan's ranges, the tracker's discs and output rows, a look, an estimate
    beams = int(lidar_s[lidar.LD_BEAMS]) if lidar_on else 0
    ranges = np.empty(beams)
    discs = np.empty((beams, N_DISC))
    points = np.empty((beams, 2))
    rows = np.empty((seen_radii.shape[1], N_OBSTACLE_ROW))
    look = np.empty(2)
    fused = np.empty(N_ESTIMATE)
    h = run[U_H]
    step_ns = int(run[U_STEP_NS])
    has_target = run[U_HAS_TARGET] != 0.0
    sensors = run[U_SENSORS] != 0.0
    estimate = run[U_ESTIMATE] != 0.0
    friction = run[U_FRICTION]
    monitor = run[U_MONITOR] != 0.0 and radii.shape[0] > 0 and has_target  # as PlannerReference
    agents_stepped = run[U_AGENTS_STEPPED] != 0.0
    derive = reads_derivative(run)
    c = c.copy()
    for q in range(lo, hi):
        j = running[q]
        ended[q] = False
        step_count = results[j, Z_PHYSICS_STEPS]
        k = int(step_count) // int(run[U_STEPS_PER_CONTROL])  # the samples before this one
        t = step_count * h
        ts = stamp_seconds_of(int(step_count) * step_ns)  # t as the nodes read the state's stamp
        x = states[j, S_XC]  # the truth, for the world's assessment
        y = states[j, S_YC]
        # an ideal IMU on the axle: the body's pitch (from the imu's quaternion) and pitch rate
        pitch, _imu_yaw = pitch_yaw_read_back(0.0, states[j, S_TH], states[j, S_PSI])
        pitch_rate = states[j, S_THD]
        odom_x = x  # what odom says, for the planner and the velocity loop
        odom_y = y
        odom_yaw = states[j, S_PSI]
        odom_velocity = states[j, S_XD]
        yaw_rate = states[j, S_PSID]
        if has_target and loop[j, L_NEW_PLAN] != 0.0 and takes_effect(loop[j, L_PLAN_STAMP], ts):
            loop[j, L_V_REF] = loop[j, L_NEXT_V]  # as controller_node takes a cmd_vel (VelocityCommand)
            loop[j, L_W_REF] = loop[j, L_NEXT_W]
            loop[j, L_COMMAND_STAMP] = ts
            loop[j, L_NEW_PLAN] = 0.0
            loop[j, L_COMMANDED] = 1.0
        derived = loop[j, L_DERIVED] != 0.0  # by the physics, in lanes
        loop[j, L_DERIVED] = 0.0
        if derive and not derived:  # under the command applied now
            derivatives(params[j], states[j], loop[j, L_LEFT], loop[j, L_RIGHT], derivative[j])
        if sensors:  # as Simulator.sense: the imu, then the encoders, once per state
            imu_sample(params[j], imu_c, imu_m[j], generators[j], states[j], derivative[j], reading[j])
            encoder_sample(params[j], encoder_c, encoder_m[j], states[j], odometry[j])
            odom_x = odometry[j, J_X]
            odom_y = odometry[j, J_Y]
            odom_yaw = odometry[j, J_YAW]
            odom_velocity = odometry[j, J_VELOCITY]
            yaw_rate = odometry[j, J_YAW_RATE]
            pitch, _imu_yaw = pitch_yaw_read_back(reading[j, RD_ROLL], reading[j, RD_PITCH], reading[j, RD_YAW])
            pitch_rate = reading[j, RD_GYRO + 1]
            if estimate:
                estimator_update(estimator_q, estimator_m[j], ts, pitch_rate, reading[j, RD_ACCEL],
                                 reading[j, RD_ACCEL + 2], odom_velocity)
                pitch = estimator_m[j, E_PITCH]
                pitch_rate = estimator_m[j, E_PITCH_RATE]
        # odom's orientation (the true pitch, odom's yaw) as the planner, tracker and monitor read it
        odom_pitch, odom_yaw = pitch_yaw_read_back(0.0, states[j, S_TH], odom_yaw)
        v_ref = loop[j, L_V_REF]
        if monitor and loop[j, L_COMMANDED] != 0.0:  # the controller node's collision monitor, on the list
            # of before this state (CollisionMonitor: a list applies from the state after its stamp)
            if lidar_on:  # on the tracker's list
                count = int(loop[j, L_SEEN_COUNT])
                v_ref = allowed_speed(v_ref, odom_x, odom_y, odom_yaw, seen_positions[j, :count],
                                      seen_velocities[j, :count], seen_radii[j, :count], ts - loop[j, L_SEEN_T],
                                      run[U_FOOTPRINT], run[U_STOP_MARGIN], run[U_DECELERATION], run[U_REACTION_TIME])
            else:  # on the world's
                v_ref = allowed_speed(v_ref, odom_x, odom_y, odom_yaw, positions[j], velocities[j], radii,
                                      ts - loop[j, L_WORLD_T], run[U_FOOTPRINT], run[U_STOP_MARGIN],
                                      run[U_DECELERATION], run[U_REACTION_TIME])
            if v_ref != loop[j, L_V_REF]:
                results[j, Z_COLLISION_LIMITED] += 1
        if friction > 0.0:
            if not derived:
                wheel_loads(params[j], states[j], derivative[j], loads[j])
            now_lifted, now_slipping = traction_flags(loads[j], friction)
            results[j, Z_LIFT_EVENTS] += 1 if now_lifted and loop[j, L_LIFTED] == 0.0 else 0
            results[j, Z_SLIP_EVENTS] += 1 if now_slipping and loop[j, L_SLIPPING] == 0.0 else 0
            loop[j, L_LIFTED_SAMPLES] += 1 if now_lifted else 0
            loop[j, L_SLIPPING_SAMPLES] += 1 if now_slipping else 0
            loop[j, L_LIFTED] = 1.0 if now_lifted else 0.0
            loop[j, L_SLIPPING] = 1.0 if now_slipping else 0.0
        results[j, Z_PITCH_ERROR_SQUARES] += (pitch - states[j, S_TH]) ** 2
        if agents_stepped:  # as World.advance_to in Simulator.advance: the agents see the robot now
            loop[j, L_AGENT_STEPS] = agents_advance(agents[j], waypoints[j], agent_state[j], loop[j, L_AGENT_STEPS], t,
                                                    x, y, params[j, P_ROBOT_RADIUS])
        # the velocity loop's speed: odom's, or the estimator's fused one
        velocity = estimator_m[j, E_VELOCITY_ESTIMATE] if estimate else odom_velocity
        if is_due(t, loop[j, L_WORLD_NEXT]):  # the world's assessment, at the world rate
            loop[j, L_WORLD_NEXT] = next_due(t, loop[j, L_WORLD_NEXT], run[U_WORLD_PERIOD])
            agents_at(agents[j], agent_state[j], loop[j, L_AGENT_STEPS], t, positions[j], velocities[j])
            loop[j, L_WORLD_T] = ts  # the stamp of the world message
            collisions_before = tally[j, W_COLLISIONS]
            clearance, hit = assess_obstacles(positions[j], radii, params[j, P_ROBOT_RADIUS], x, y, tally[j])
            results[j, Z_MIN_CLEARANCE] = min(results[j, Z_MIN_CLEARANCE], clearance)
            if results[j, Z_HIT_OBSTACLE] < 0 and tally[j, W_COLLISIONS] > collisions_before:
                results[j, Z_HIT_OBSTACLE] = hit
                if detected[j, hit]:
                    results[j, Z_DETECTED:Z_DETECTED + 6] = detected_at[j, hit]
                else:  # it came into range and hit between two plans: the robot now
                    results[j, Z_DETECTED:Z_DETECTED + 6] = (t, x, y, states[j, S_PSI], states[j, S_XD],
                                                             states[j, S_PSID])
            if has_target and math.isnan(results[j, Z_REACHED_AT]):
                tx, ty, _heading, _vx, _vy = target_at(segments[j], run[U_TARGET_SPEED], t)
                if math.hypot(tx - x, ty - y) <= run[U_CAPTURE_RADIUS]:
                    results[j, Z_REACHED_AT] = t
        if lidar_on and is_due(t, loop[j, L_SCAN_NEXT]):  # as sim_node's scan and tracker_node on it
            loop[j, L_SCAN_NEXT] = next_due(t, loop[j, L_SCAN_NEXT], run[U_SCAN_PERIOD])
            agents_at(agents[j], agent_state[j], loop[j, L_AGENT_STEPS], t, positions[j], velocities[j])
            lidar.cast_scan(lidar_s, x, y, states[j, S_PSI], states[j, S_TH], states[j, S_XD], states[j, S_PSID],
                            params[j, P_R], positions[j], velocities[j], radii, ranges)
            lidar.scan_noise(lidar_s, lidar_generators[j], ranges)
            for b in range(beams):
                ranges[b] = np.float32(ranges[b])  # as a LaserScan carries them
            count = tracker_scan(detection_d, tracking_k, walls_w, surfaces_u, tracks[j], track_cov[j], walls[j],
                                 surfaces[j], track_counters[j], ts, ranges, run[U_SCAN_ANGLE_MIN],
                                 run[U_SCAN_ANGLE_INCREMENT], run[U_SCAN_TIME_INCREMENT], odom_x, odom_y, odom_yaw,
                                 odom_velocity, yaw_rate, odom_pitch, run[U_AXLE_HEIGHT], run[U_LIDAR_HEIGHT], discs,
                                 points, rows)
            for r in range(count):
                seen_positions[j, r, 0] = rows[r, 1]
                seen_positions[j, r, 1] = rows[r, 2]
                seen_velocities[j, r, 0] = rows[r, 3]
                seen_velocities[j, r, 1] = rows[r, 4]
                seen_radii[j, r] = rows[r, 5]
            loop[j, L_SEEN_COUNT] = count
            judge_lists(results[j, Z_TRACKING:Z_TRACKING + N_JUDGE], track_born[j], track_judged[j], ts, rows, count,
                        positions[j], velocities[j], radii, x, y, lidar_s[lidar.LD_RANGE_MAX], GATE, SETTLE)
            loop[j, L_SEEN_T] = ts
        if looks and has_target and is_due(t, loop[j, L_LOOK_NEXT]):  # the detector's look, fused
            loop[j, L_LOOK_NEXT] = next_due(t, loop[j, L_LOOK_NEXT], run[U_LOOK_PERIOD])
            tx, ty, _heading, _vx, _vy = target_at(segments[j], run[U_TARGET_SPEED], t)
            agents_at(agents[j], agent_state[j], loop[j, L_AGENT_STEPS], t, positions[j], velocities[j])
            if measure_target(look_s, look_generators[j], x, y, states[j, S_PSI], states[j, S_TH], tx, ty,
                              positions[j], radii, look):
                distance, bearing = detection_read_back(look[0], look[1])  # from the PoseArray it is sent as
                target_measure(target_s[j], target_memory[j], target_cov[j], ts, distance, bearing, odom_x, odom_y,
                               odom_yaw, odom_pitch)
            known = target_estimate(target_s[j], target_memory[j], target_cov[j], ts, fused)
            loop[j, L_TARGET_KNOWN] = 1.0 if known else 0.0
            if known:
                loop[j, L_TARGET_X] = fused[0]
                loop[j, L_TARGET_Y] = fused[1]
                heading, speed = heading_speed(fused[2], fused[3])  # the target's odometry, as the planner reads it
                loop[j, L_TARGET_VX], loop[j, L_TARGET_VY] = target_velocity_read_back(heading, speed)
        if has_target:
            if is_due(t, loop[j, L_PLAN_NEXT]):  # the planner, at its rate, on the world at time t
                loop[j, L_PLAN_NEXT] = next_due(t, loop[j, L_PLAN_NEXT], run[U_PLANNER_PERIOD])
                tx, ty, heading, _vx, _vy = target_at(segments[j], run[U_TARGET_SPEED], t)
                tvx, tvy = target_velocity_read_back(heading, run[U_TARGET_SPEED])  # the world's target message
                if looks:  # the fused target of the last look (a runner's tracker always has a prior)
                    tx = loop[j, L_TARGET_X]
                    ty = loop[j, L_TARGET_Y]
                    tvx = loop[j, L_TARGET_VX]
                    tvy = loop[j, L_TARGET_VY]
                agents_at(agents[j], agent_state[j], loop[j, L_AGENT_STEPS], t, positions[j], velocities[j])
                if lidar_on:  # the last scan's obstacles moved to now, as planner_node moves them
                    count = int(loop[j, L_SEEN_COUNT])
                    age = max(0.0, ts - loop[j, L_SEEN_T])
                    for r in range(count):
                        plan_positions[j, r, 0] = seen_positions[j, r, 0] + seen_velocities[j, r, 0] * age
                        plan_positions[j, r, 1] = seen_positions[j, r, 1] + seen_velocities[j, r, 1] * age
                    plan_step(a, memory[j], ring[j], plan_out[j], ts, odom_x, odom_y, odom_yaw, odom_velocity, tx, ty,
                              tvx, tvy, plan_positions[j, :count], seen_velocities[j, :count], seen_radii[j, :count],
                              seen_distances[j, :count])
                    # the world's obstacles' clearances, for the avoidability check's bookkeeping below
                    clearances(odom_x, odom_y, positions[j], radii, a[A_ROBOT_RADIUS], distances[j])
                else:
                    plan_step(a, memory[j], ring[j], plan_out[j], ts, odom_x, odom_y, odom_yaw, odom_velocity, tx, ty,
                              tvx, tvy, positions[j], velocities[j], radii, distances[j])
                loop[j, L_NEXT_V] = plan_out[j, Q_V]
                loop[j, L_NEXT_W] = plan_out[j, Q_OMEGA]
                loop[j, L_NEW_PLAN] = 1.0
                loop[j, L_PLAN_STAMP] = ts
                stuck = plan_out[j, Q_MODE] == STUCK
                results[j, Z_STUCK_AT_END] = 1.0 if stuck else 0.0
                if stuck:
                    results[j, Z_STUCK_STEPS] += 1
                results[j, Z_FINAL_DISTANCE] = plan_out[j, Q_DISTANCE]
                for o in range(radii.shape[0]):
                    inside = distances[j, o] <= a[A_RHO_O]
                    if inside and not detected[j, o]:
                        detected_at[j, o, 0] = t
                        detected_at[j, o, 1] = x
                        detected_at[j, o, 2] = y
                        detected_at[j, o, 3] = states[j, S_PSI]
                        detected_at[j, o, 4] = states[j, S_XD]
                        detected_at[j, o, 5] = states[j, S_PSID]
                    detected[j, o] = inside
        else:
            v_ref, w_ref = command_profile_at(profile[0], profile[1], profile[2], t)
            loop[j, L_V_REF] = v_ref
            loop[j, L_W_REF] = w_ref
            loop[j, L_COMMAND_STAMP] = ts  # a command profile: a command at every sample
        hold = estimate and estimator_m[j, E_CALIBRATING] != 0.0
        cascade_compute(c, control[j], control_out[j], ts, v_ref, loop[j, L_W_REF], velocity, yaw_rate, pitch,
                        pitch_rate, loop[j, L_COMMANDED] == 0.0, hold, loop[j, L_COMMAND_STAMP])
        true_pitch = states[j, S_TH]
        results[j, Z_PITCH_MIN] = min(results[j, Z_PITCH_MIN], true_pitch)
        results[j, Z_PITCH_MAX] = max(results[j, Z_PITCH_MAX], true_pitch)
        if t >= SETTLING_TIME:
            results[j, Z_PITCH_SETTLED] = max(results[j, Z_PITCH_SETTLED], abs(true_pitch))
        if traces.shape[1] > 0:  # (1, 0, N_TRACE): nothing recorded
            traces[j, k, T_T] = t
            traces[j, k, T_X_C] = x
            traces[j, k, T_Y_C] = y
            traces[j, k, T_PITCH] = pitch  # what the controller used
            traces[j, k, T_VELOCITY] = velocity
            traces[j, k, T_YAW] = states[j, S_PSI]
            traces[j, k, T_LEFT_TORQUE] = control_out[j, O_LEFT]
            traces[j, k, T_RIGHT_TORQUE] = control_out[j, O_RIGHT]
            traces[j, k, T_VELOCITY_REF] = control_out[j, O_VELOCITY_REF]
            traces[j, k, T_YAW_RATE_REF] = control_out[j, O_YAW_RATE_REF]
            traces[j, k, T_PITCH_TRUE] = true_pitch
            traces[j, k, T_VELOCITY_TRUE] = states[j, S_XD]
        results[j, Z_SIM_TIME] = ts  # as the last state's stamp reads (the graph's sim_time_s)
        results[j, Z_SAMPLES] = k + 1
        torque_limit = torque_limits[j]
        left = min(max(control_out[j, O_LEFT], -torque_limit), torque_limit)  # the motor driver's limit
        right = min(max(control_out[j, O_RIGHT], -torque_limit), torque_limit)
        if k > 0:  # what the motors feel as a jolt (issue 35: a sawtooth at the planner's rate)
            results[j, Z_TORQUE_STEP_MAX] = max(results[j, Z_TORQUE_STEP_MAX], abs(left - loop[j, L_LEFT]),
                                                abs(right - loop[j, L_RIGHT]))
        if (k == int(run[U_N_SAMPLES]) - 1 or results[j, Z_FALLEN] != 0.0
                or (run[U_END_ON_TARGET] != 0.0 and not math.isnan(results[j, Z_REACHED_AT]))):
            ended[q] = True
            robot_end(run, results, memories, j)
            continue
        loop[j, L_LEFT] = left
        loop[j, L_RIGHT] = right


@parallel_kernel
def _run_robots(params, states, c, a, run, segments, draws, agents, waypoints, radii, profile,
                results, traces, imu_c, imu_m, generators, encoder_c, encoder_m, estimator_q, lidar_s,
                lidar_generators, look_s, look_generators, detection_d, tracking_k, walls_w, surfaces_u, target_s, lanes,
                threads):
    """All robots' runs, sample by sample: every running robot's sample (_samples, a share of the robots per
    thread), then their physics until the next sample in groups of `lanes` robots
    (dynamics.advance_upright_lanes, in parallel over the groups, vectorised over a group's robots). A
    robot whose run has ended leaves the groups, so they stay full. Every robot's result is the same to
    the bit whoever its neighbours are (test_batch); a group whose robots need different numbers of RK4
    sub-steps, and the last SERIAL_ROBOTS robots, step robot by robot (dynamics.advance_upright).

    params: robot parameters (robot_params.ROBOT_LAYOUT), states (dynamics.STATE_LAYOUT), c: controller
    settings (cascade.SETTINGS_LAYOUT), a: planner settings (apf.SETTINGS_LAYOUT), run: RUN_LAYOUT; each
    robot's target segment and yaw-rate draws, obstacles' motions (agents.AGENT_LAYOUT) and waypoints [m]; the radii [m]; the
    command profile (three rows: t [s], v [m/s], omega [rad/s]); results: RESULT_LAYOUT rows; traces: rows of
    TRACE_LAYOUT per robot; the sensors' settings, each robot's sensor memories and generator, and the
    estimator's settings, used when run[U_SENSORS] is set (ideal sensors read the state directly); and
    perception's (PERCEPTION_ARRAYS), used when run[U_LIDAR] is set."""
    n = params.shape[0]
    n_params = params.shape[1]
    h = run[U_H]
    steps_per_control = int(run[U_STEPS_PER_CONTROL])
    lidar_on = run[U_LIDAR] != 0.0
    memories = new_memories(n, run, radii.shape[0], int(tracking_k[TS_MAX_TRACKS]) if lidar_on else 0,
                            output_rows(tracking_k, walls_w) if lidar_on else 0,
                            int(walls_w[WM_MAX_DISCS]) if lidar_on else 0)
    loop, derivative, loads = memories[MA_LOOP], memories[MA_DERIVATIVE], memories[MA_LOADS]
    world = (segments, agents, waypoints, radii, profile)  # WORLD_ARRAYS
    sensors = (imu_c, imu_m, generators, encoder_c, encoder_m, estimator_q)  # SENSOR_ARRAYS
    perception = (lidar_s, lidar_generators, look_s, look_generators, detection_d, tracking_k, walls_w, surfaces_u,
                  target_s)
    friction = run[U_FRICTION]
    derive = reads_derivative(run)
    torque_limits = np.empty(n)
    for i in range(n):
        robot_begin(i, run, results[i], memories, imu_c, imu_m[i], generators[i], agents[i])
        torque_limits[i] = wheel_torque_limit(params[i])
    n_subs = robot_substeps(params, h)
    serial_work = np.empty((WORK_ROWS, N_STATE))  # the last few robots' physics, one by one
    serial_fell = np.zeros(SERIAL_ROBOTS, dtype=np.bool_)
    running = np.arange(n)  # the robots whose run goes on, in order
    ended = np.zeros(n, dtype=np.bool_)
    n_running = n
    while n_running > 0:
        if n_running <= SERIAL_ROBOTS:  # so few that starting the threads costs more than they save
            _samples(running, np.int64(0), n_running, ended, params, states, c, a, run, world, sensors, perception,
                     results, traces, torque_limits, memories)
        else:
            share = (n_running + threads - 1) // threads
            for g in prange(threads):
                _samples(running, min(g * share, n_running), min((g + 1) * share, n_running), ended, params,
                         states, c, a, run, world, sensors, perception, results, traces, torque_limits, memories)
        m = 0
        for q in range(n_running):
            if not ended[q]:
                running[m] = running[q]
                m += 1
        n_running = m
        if m <= SERIAL_ROBOTS:
            for q in range(m):
                i = running[q]
                serial_fell[q] = advance_upright(params[i], states[i], loop[i, L_LEFT], loop[i, L_RIGHT], h,
                                                 steps_per_control, serial_work)
            robots_moved(run, results, segments, draws, running, 0, m, serial_fell)
            continue
        # groups of up to `lanes` robots, and at least one per thread while there are robots for it; each
        # thread steps a share of the groups with one set of lane arrays (allocating them per group cost
        # an allocation and a free per array, group and sample)
        group = min(lanes, (m + threads - 1) // threads)
        n_groups = (m + group - 1) // group
        for w in prange(threads):
            p, s, left, right, work, moving, fell = lane_group(n_params)
            ds = np.empty((N_STATE, LANES))
            wl = np.empty((N_TRACTION_OUTPUTS, LANES))
            one = np.empty((WORK_ROWS, N_STATE))
            for g in range(w * n_groups // threads, (w + 1) * n_groups // threads):
                lo = g * group
                size = min(m, lo + group) - lo
                moving[:] = True
                fell[:] = False
                if shared_substeps(n_subs, running, lo, size) > 0:
                    for j in range(size):
                        i = running[lo + j]
                        for k in range(n_params):
                            p[k, j] = params[i, k]
                        for k in range(N_STATE):
                            s[k, j] = states[i, k]
                        left[j] = loop[i, L_LEFT]
                        right[j] = loop[i, L_RIGHT]
                    advance_upright_lanes(p, s, left, right, h, steps_per_control, work, size, moving, fell)
                    from_lanes(s, states, running, lo, size)
                    if derive:  # the next sample's derivative and wheel loads, vectorised here
                        derive_lanes(p, s, left, right, ds, wl, size, friction)
                        from_lanes(ds, derivative, running, lo, size)
                        from_lanes(wl, loads, running, lo, size)
                        for j in range(size):
                            loop[running[lo + j], L_DERIVED] = 1.0
                else:
                    for j in range(size):
                        i = running[lo + j]
                        fell[j] = advance_upright(params[i], states[i], loop[i, L_LEFT], loop[i, L_RIGHT], h,
                                                  steps_per_control, one)
                robots_moved(run, results, segments, draws, running, lo, size, fell)


def group_size(n: int) -> int:
    """Robots stepped together: up to dynamics.LANES, and small enough that every thread has groups."""
    return max(1, min(LANES, -(-n // get_num_threads())))


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
    lanes: int | None = None,
    perception: str = "truth",
    tracker: Mapping[str, Any] | None = None,
) -> BatchResult:
    """Run len(seeds) robots of `scenario`; robot i has the parameter vector params[i] (robot_params) and
    the world (and sensor noise) of seeds[i]. Settings default to the parameter tables (the planner's under
    what the scenario pins; `sim`: the simulator's sensor and traction parameters, imu.*, encoder.*,
    traction.*, lidar.*, target_sensor.*); `duration` to the scenario's. `lanes`: robots stepped together
    (group_size by default). `perception` "lidar": the planner and the collision monitor on what the
    tracker (`tracker`: tracker_node's parameters) makes of the simulated scan and target detector, as the
    runner's graph with --perception lidar (the target's start handed to the tracker as its prior)."""
    n = len(seeds)
    params = np.ascontiguousarray(params, dtype=float)
    if n < 1 or params.shape[0] != n:
        raise ConfigError(f"batch: {n} seeds and {params.shape[0]} parameter rows: need as many, at least 1")
    lanes = group_size(n) if lanes is None else lanes
    if not 1 <= lanes <= min(n, LANES):
        raise ConfigError(f"batch: lanes={lanes}: need 1 to the number of robots ({n}), at most {LANES}")
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
    motions = [agent_arrays(s.obstacles, seed) for s, seed in zip(layouts, seeds, strict=True)]
    agents = np.stack([spec for spec, _ in motions])
    waypoints = np.stack([route for _, route in motions])
    radii = np.array([o.radius for o in sc.obstacles], dtype=float)
    profile = np.ascontiguousarray(np.stack(command_profile(sc)))
    run = RUN_LAYOUT.pack({
        "h": 1.0 / physics_rate, "step_ns": step_nanoseconds(physics_rate), "steps_per_control": steps_per_control,
        "n_samples": n_samples,
        "planner_period": 1.0 / planner_rate, "world_period": 1.0 / world_rate, "has_target": tgt is not None,
        "end_on_target": sc.end_on_target, "target_speed": tgt.speed if tgt else 0.0,
        "turn_interval": tgt.turn_interval if tgt else 1.0, "capture_radius": tgt.capture_radius if tgt else 0.0,
        "ring_rows": progress_capacity(planner_cfg["stuck_time"], planner_rate),
        "sensors": 0.0, "estimate": 0.0, "friction": 0.0,
        "monitor": control_cfg["collision_monitor.enabled"], "footprint": control_cfg["collision_monitor.footprint_radius"],
        "stop_margin": control_cfg["collision_monitor.stop_margin"],
        "deceleration": control_cfg["collision_monitor.deceleration"],
        "reaction_time": control_cfg["collision_monitor.reaction_time"],
        "agents_stepped": bool(stepped(agents[0])),
        **dict.fromkeys(("lidar", "scan_period", "look_period", "axle_height", "lidar_height", "scan_angle_min",
                         "scan_angle_increment", "scan_time_increment"), 0.0),  # set below
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
    lidar_on = perception == "lidar" and tgt is not None  # without a planner there is nothing to see for
    if perception not in ("truth", "lidar"):
        raise ConfigError(f"batch: perception {perception!r}: need 'truth' or 'lidar'")
    if lidar_on and sim_cfg["lidar.rate"] <= 0.0:
        raise ConfigError("batch: perception 'lidar' with lidar.rate = 0: the robot has no LiDAR")
    tracker_cfg = validate_all((*TRACKER_SPECS, *TARGET_SPECS),
                               {**defaults((*TRACKER_SPECS, *TARGET_SPECS)), **(tracker or {})})
    lidar_s = lidar.settings_vector(sim_cfg)
    tracking_k = track_vector(tracker_cfg)
    look_rate = sim_cfg["target_sensor.rate"] if lidar_on else 0.0
    target_s = np.tile(target_vector(tracker_cfg), (n, 1))
    if tgt is not None:  # each robot's tracker told where its layout's target starts
        target_s[:, [TG_PRIOR_X, TG_PRIOR_Y]] = [(s.target.x, s.target.y) for s in layouts]
        target_s[:, TG_PRIOR_STD] = MISSION_PRIOR_STD
    run[U_LIDAR] = 1.0 if lidar_on else 0.0
    run[U_SCAN_PERIOD] = 1.0 / sim_cfg["lidar.rate"] if sim_cfg["lidar.rate"] > 0.0 else 0.0
    run[U_LOOK_PERIOD] = 1.0 / look_rate if look_rate > 0.0 else 0.0
    run[U_AXLE_HEIGHT] = tracker_cfg["axle_height"]
    run[U_LIDAR_HEIGHT] = tracker_cfg["lidar_height"]
    # the angle fields as a LaserScan carries them (float32), as scan_messages.laser_scan fills them
    run[U_SCAN_ANGLE_MIN] = np.float32(sim_cfg["lidar.angle_min"])
    run[U_SCAN_ANGLE_INCREMENT] = np.float32(sim_cfg["lidar.angle_increment"])
    run[U_SCAN_TIME_INCREMENT] = np.float32(run[U_SCAN_PERIOD] / lidar_s[lidar.LD_BEAMS])
    lidar_generators = np.stack([new_generator(seed, lidar.LIDAR_STREAM) for seed in seeds])
    look_generators = np.stack([new_generator(seed, TARGET_SENSOR_STREAM) for seed in seeds])
    results = np.zeros((n, N_RESULT))
    traces = np.zeros((n, n_samples, N_TRACE)) if record else np.zeros((1, 0, N_TRACE))
    with parallel_chunksize(0):  # equal shares: the running robots are kept together
        _run_robots(params, states, control_vector(control_cfg), planner_vector(planner_cfg), run, segments, draws,
                    agents, waypoints, radii, profile, results, traces, imu_c, imu_m, generators,
                    encoder_c, encoder_m, estimator_vector(control_cfg), lidar_s, lidar_generators,
                    look_vector(sim_cfg), look_generators, detection_vector(tracker_cfg), tracking_k,
                    wall_vector(tracker_cfg), surface_vector(tracker_cfg), target_s, lanes, get_num_threads())
    return BatchResult(results, traces if record else None, physics_rate)
