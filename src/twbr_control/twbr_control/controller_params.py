"""The controller's parameters: one table for the node, the headless closed loop, the tuner and docs/parameters.md.

The gain defaults are the ones config/controller.yaml carries (tools/tune_gains.py, see there).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from twbr_common.params import ConfigError, ParamSpec, defaults, tunable, validate_all
from twbr_control.cascade import SMOOTHING_SAMPLES
from twbr_control.collision_monitor import MONITOR_SPECS
from twbr_control.lqr import LQR_SPECS
from twbr_sim.robot_limits import ROBOT_FILE_SPEC, RobotLimits, at_most, limits_from_file

GAIN_SPECS: tuple[ParamSpec, ...] = tunable(
    ParamSpec("velocity.kp", 0.4129, "velocity loop: pitch reference per m/s of speed error", "rad·s/m", 0.0, 100.0),
    ParamSpec("velocity.ki", 0.6697, "velocity loop: integral gain", "rad/m", 0.0, 100.0),
    ParamSpec("velocity.kd", 0.0, "velocity loop: derivative gain on the measured speed", "rad·s²/m", 0.0, 100.0),
    ParamSpec("velocity.setpoint_weight", 0.4181, "velocity loop: weight b of v_ref in the proportional term"
              " (b*v_ref - v); b < 1 means less overshoot and roll-back on a step", "", 0.0, 1.0),
    ParamSpec("velocity.measurement_filter", 0.0, "velocity loop: low-pass time constant on the measured speed (an"
              " encoder's speed moves in whole counts); 0: none", "s", 0.0, 1.0),
    ParamSpec("yaw_rate.measurement_filter", 0.0, "yaw-rate loop: low-pass time constant on the measured yaw rate;"
              " 0: none", "s", 0.0, 1.0),
    ParamSpec("velocity.derivative_filter", 0.02, "velocity loop: low-pass time constant of the derivative", "s",
              0.0, 1.0),
    ParamSpec("pitch.kp", 48.81, "pitch loop: common wheel torque per rad of pitch error", "N·m/rad", 0.0, 10000.0),
    ParamSpec("pitch.ki", 0.0, "pitch loop: integral gain", "N·m/(rad·s)", 0.0, 10000.0),
    ParamSpec("pitch.kd", 9.667, "pitch loop: derivative gain on the measured pitch rate", "N·m·s/rad", 0.0, 1000.0),
    ParamSpec("pitch.derivative_filter", 0.005, "pitch loop: low-pass time constant of the derivative", "s",
              0.0, 1.0),
    ParamSpec("yaw_rate.kp", 3.429, "yaw-rate loop: differential torque per rad/s of error", "N·m·s/rad", 0.0, 1000.0),
    ParamSpec("yaw_rate.ki", 0.9293, "yaw-rate loop: integral gain", "N·m/rad", 0.0, 1000.0),
    ParamSpec("yaw_rate.setpoint_weight", 1.0, "yaw-rate loop: weight b of omega_ref in the proportional term"
              " (b*omega_ref - omega); b < 1: a command step moves the differential torque by b times less", "",
              0.0, 1.0),
)

CONTROL_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("controller", "pid", "balance and yaw control law: the paper's cascaded PID (pid), or LQR on the"
              " linearised model of lqr.robot_file, gains computed at start-up (lqr)", choices=("pid", "lqr")),
    ParamSpec("rate", 200.0, "control rate: one command per state at most this often (in lockstep, set the"
              " simulator's publish_rate to it)", "Hz", 1.0, 2000.0),
    *tunable(ParamSpec("max_velocity_ref", 1.5, "cmd_vel linear.x is clipped to +-this", "m/s", 0.0, 10.0, low_open=True),
    ParamSpec("max_yaw_rate_ref", 3.0, "cmd_vel angular.z is clipped to +-this", "rad/s", 0.0, 20.0, low_open=True),
    ParamSpec("reference_rate.velocity", 0.3621, "largest rate of change of v_ref the velocity loop sees: a step"
              " becomes a ramp and asks for less roll-back; a planner's commands, limited by its own"
              " max_acceleration, pass as they are; 0: no limit", "m/s²", 0.0, 100.0),
    ParamSpec("reference_rate.yaw_rate", 0.0, "largest rate of change of omega_ref the yaw-rate loop sees (a"
              " step becomes a ramp); 0: no limit", "rad/s²", 0.0, 1000.0),
    ParamSpec("reference_hold.yaw_rate", 1.25, "between two cmd_vel, omega_ref goes on along the commands' slope"
              " when it is at most this (a planner slewing omega, its max_yaw_acceleration 1 rad/s² with room for"
              " a sample of jitter): its 20 Hz steps reach the yaw-rate loop as the ramp they sample, without lag;"
              " a steeper jump is a step and applies at once; 0: each command held as it comes", "rad/s²",
              0.0, 1000.0),
    ParamSpec("reference_hold.velocity", 0.15, "between two cmd_vel, v_ref goes on along the commands' slope when"
              " it is at most this (a planner slewing v at its max_acceleration 0.06 or brake_deceleration 0.12"
              " m/s², with room for jitter): its 20 Hz steps reach the velocity loop as the ramp they sample, not"
              " as a torque sawtooth at 20 Hz; a steeper jump is a step (then reference_rate.velocity); 0: each"
              " command held as it comes", "m/s²", 0.0, 100.0),
    ParamSpec("reference_hold.catch_up", 3.0, "the held references close their gap to the commands over this many"
              " command intervals while following the commands' slope: where a planner's acceleration changes by"
              " D the line bends by D (1 + 1/catch_up); 1 closes it within one interval and bends by 2 D and back,"
              " a jolt of the wheel torques where the planner reverses its turn", "intervals", 1.0, 100.0),
    ParamSpec("reference_smoothing.yaw_rate", 0.0, "the yaw-rate loop sees the mean of the held omega_ref over"
              " this window while the planner ramps it: where its yaw acceleration reverses from one command to the"
              " next, the bend is spread over the window (lag: half of it) instead of one jolt of the wheel"
              " torques, at the cost of lag in the planner's steering loop (docs/nodes.md); steps and stale commands"
              " pass at once; at most 64 control periods; 0: none", "s",
              0.0, 0.32),
    ParamSpec("reference_smoothing.velocity", 0.0, "the same for v_ref: the velocity loop sees the mean of the"
              " held v_ref over this window while the planner ramps it; the collision monitor's limit applies"
              " at once; at most 64 control periods; 0: none", "s", 0.0, 0.32),
    ParamSpec("reference_jerk.yaw_rate", 40.0, "largest rate of change of the slope of the omega_ref the yaw-rate"
              " loop sees: where the held omega_ref bends (the planner reverses its turn) the bend starts at once"
              " and is spread over bend / jerk seconds instead of one jolt of the wheel torques of K_p times the"
              " bend times the sample time; a ramp passes as it is, a step and a stale command at once; 0: no limit",
              "rad/s³", 0.0, 10000.0),
    ParamSpec("reference_jerk.velocity", 2.0, "the same for v_ref, also on the ramps of reference_rate.velocity"
              " (a step, a stale command, the collision monitor's limit: their deceleration comes within"
              " reference_rate.velocity / jerk seconds); 0: no limit", "m/s³", 0.0, 10000.0),
    ParamSpec("max_pitch_ref", 0.15, "limit of the velocity loop's pitch reference", "rad", 0.0, 0.6,
              low_open=True),
    ParamSpec("pitch_offset", 0.0, "pitch of the balanced robot at rest (centre of mass not above the axle)",
              "rad", -0.3, 0.3),
    ParamSpec("max_wheel_torque", 15.0, "motor torque limit per wheel: commands are limited to it", "N·m",
              0.0, 1000.0, low_open=True),
    ParamSpec("fall_pitch", 0.6, "|pitch - pitch_offset| past this is a fall: zero torque until re-enabled",
              "rad", 0.05, 1.5)),
    ParamSpec("pitch_source", "auto", "where pitch and pitch rate come from: the imu's orientation and"
              " angular_velocity.y (orientation), the estimator on gyro and accelerometer (estimator), or the"
              " estimator only when the imu reports no orientation, orientation_covariance[0] = -1 (auto)",
              choices=("auto", "orientation", "estimator")),
    ParamSpec("estimator.time_constant", 1.0, "estimator: time constant with which the accelerometer's gravity"
              " direction corrects the integrated gyro (shorter: follows the accelerometer's noise and the"
              " robot's accelerations more)", "s", 0.01, 10.0),
    ParamSpec("estimator.bias_time_constant", 5.0, "estimator: time constant of the gyro bias estimate; 0: no"
              " bias estimation", "s", 0.0, 1000.0),
    ParamSpec("estimator.calibration_time", 0.5, "estimator: for this long after its first reading the robot stands"
              " still on its stand and the controller holds zero torque: the gyro's mean reading is its bias, the"
              " accelerometer's its pitch (a moving reading ends it early); 0: none", "s", 0.0, 60.0),
    ParamSpec("estimator.velocity_time_constant", 0.1, "estimator: time constant with which the odometry's speed"
              " corrects the accelerometer's integrated forward acceleration (the velocity loop then sees a speed"
              " without an encoder's count steps); 0: the odometry's speed as it is", "s", 0.0, 10.0),
    ParamSpec("max_sample_gap", 0.05, "a longer gap between states restarts the derivatives and caps the"
              " integration step", "s", 0.001, 1.0),
    *GAIN_SPECS,
    *tunable(*LQR_SPECS),
    *MONITOR_SPECS,
)

NODE_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("cmd_vel_timeout", 0.5, "cmd_vel older than this: references go to zero and the robot balances in"
              " place", "s", 0.01, 60.0),
    ParamSpec("state_timeout", 0.2, "odom or imu stamped this much before the node's clock is stale and dropped",
              "s", 0.001, 10.0),
    ParamSpec("sync_tolerance", 0.001, "odom and imu stamps at most this far apart form one state (the"
              " simulator stamps both alike; widen it for a driver with separate clocks)", "s", 0.0, 1.0),
    ParamSpec("enable_stamped_cmd_vel", False, "subscribe cmd_vel as geometry_msgs/TwistStamped (Nav2's name)"
              " instead of Twist"),
    ParamSpec("start_enabled", True, "command torque from the start; false waits for ~/enable (std_srvs/SetBool)"),
    ROBOT_FILE_SPEC,
)


def check_consistent(cfg: dict) -> dict:
    """Refuse combinations that no single range can: a pitch reference the fall cut-off would trip on."""
    if cfg["max_pitch_ref"] + abs(cfg["pitch_offset"]) >= cfg["fall_pitch"]:
        raise ConfigError(
            f"invalid parameter 'max_pitch_ref' = {cfg['max_pitch_ref']:g}: must be below fall_pitch"
            f" - |pitch_offset| = {cfg['fall_pitch'] - abs(cfg['pitch_offset']):g} rad"
        )
    for name in ("reference_smoothing.yaw_rate", "reference_smoothing.velocity"):
        if cfg[name] * cfg["rate"] > SMOOTHING_SAMPLES + 0.5:
            raise ConfigError(
                f"invalid parameter '{name}' = {cfg[name]:g}: must be at most {SMOOTHING_SAMPLES} control"
                f" periods, {SMOOTHING_SAMPLES / cfg['rate']:g} s at rate {cfg['rate']:g} Hz"
            )
    return cfg


def check_within_robot(cfg: dict, limits: RobotLimits) -> dict:
    """Refuse settings the robot cannot meet: references past its top speeds, a reference ramp steeper than it
    can accelerate, and a torque limit too low to hold the body at the largest pitch reference."""
    at_most(cfg, "max_velocity_ref", limits, "top_speed", "m/s")
    at_most(cfg, "max_yaw_rate_ref", limits, "top_yaw_rate", "rad/s")
    at_most(cfg, "reference_rate.velocity", limits, "max_acceleration", "m/s²")
    lean = cfg["max_pitch_ref"] + abs(cfg["pitch_offset"])
    needed = limits.holding_torque(lean)
    if cfg["max_wheel_torque"] < needed:
        raise ConfigError(
            f"invalid parameter 'max_wheel_torque' = {cfg['max_wheel_torque']:g}: must be at least {needed:.4g} N·m,"
            f" the torque per wheel that holds the body at max_pitch_ref + |pitch_offset| = {lean:g} rad against"
            f" gravity (body_mass * gravity * com_height * sin(pitch) / 2, of {limits.source}); below it the"
            " robot falls"
        )
    return cfg


def resolve(overrides: Mapping[str, Any] | None = None) -> dict:
    """The controller's settings for a headless run: the defaults with `overrides`, validated and checked
    (against the installed robot.yaml)."""
    cfg = check_consistent(validate_all(CONTROL_SPECS, {**defaults(CONTROL_SPECS), **(overrides or {})}))
    return check_within_robot(cfg, limits_from_file(""))


def describe(cfg: Mapping[str, Any]) -> str:
    """What this controller runs, for its start-up log line (the law named by `controller`, not always PID)."""
    if cfg["controller"] == "lqr":
        law = "LQR on the linearised model (speed and yaw rate with integral action; gains designed at start-up)"
    else:
        law = (f"cascaded PID (speed -> pitch -> torque, K_p {cfg['velocity.kp']:g} / {cfg['pitch.kp']:g}) and a PI"
               f" yaw-rate loop (K_p {cfg['yaw_rate.kp']:g})")
    return f"{law} at up to {cfg['rate']:g} Hz, pitch from {cfg['pitch_source']}"

