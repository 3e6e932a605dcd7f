"""The paper's cascaded controller (its Figure 3) as a compiled kernel and a small class around it.

References rate-limited each (reference_rate.*), then
velocity PID: v_ref - v -> pitch_ref (limited) ; pitch PID: pitch_ref - pitch -> common wheel torque ;
yaw-rate PI: omega_ref - omega -> differential torque. Left = common - differential, right = common +
differential, each limited to the motor torque, balance first: the differential part gets only the
headroom the common part leaves. Signs: a forward lean (pitch > 0) is caught by driving the wheels forward,
so the common torque is minus the pitch PID's output; to speed up, the robot must lean forward, so the
velocity loop's output is the pitch reference itself (and the robot first rolls back: non-minimum phase).

The sample time comes from the stamps of the states. `cascade_compute` is the one implementation: the
node, the headless closed loop and the tuner call it through `CascadeController`, the batch engine calls
it directly, on a settings vector (C_*), a memory vector (K_*) and an output vector (O_*) per robot.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from twbr_common.jit import inline_kernel, kernel
from twbr_common.layout import Layout
from twbr_control.pid import M_HAS_PREVIOUS, M_LIMITED, N_GAINS, N_MEMORY, Pid, PidGains, pid_reset, pid_update

# Settings vector: the loop's scalars (controller_params names; `period` is 1/rate), then the three PIDs'
# gains (pid.GAINS_LAYOUT each).
SETTINGS_LAYOUT = Layout((
    "period", "max_velocity_ref", "max_yaw_rate_ref", "pitch_offset", "max_wheel_torque", "fall_pitch",
    "max_sample_gap", "reference_rate.velocity", "reference_rate.yaw_rate", "reference_hold.yaw_rate",
    "reference_hold.velocity", "reference_hold.catch_up", "reference_smoothing.yaw_rate", "reference_smoothing.velocity",
    "reference_jerk.velocity", "reference_jerk.yaw_rate", "collision_monitor.release_acceleration",
    "velocity.measurement_filter",
    "yaw_rate.measurement_filter", "control_law", "lqr.setpoint_weight", ("lqr", 6), ("velocity", N_GAINS),
    ("pitch", N_GAINS), ("yaw_rate", N_GAINS),
))
C_PERIOD = SETTINGS_LAYOUT["period"]
C_MAX_V_REF = SETTINGS_LAYOUT["max_velocity_ref"]
C_MAX_W_REF = SETTINGS_LAYOUT["max_yaw_rate_ref"]
C_PITCH_OFFSET = SETTINGS_LAYOUT["pitch_offset"]
C_MAX_TORQUE = SETTINGS_LAYOUT["max_wheel_torque"]
C_FALL_PITCH = SETTINGS_LAYOUT["fall_pitch"]
C_MAX_GAP = SETTINGS_LAYOUT["max_sample_gap"]
C_V_RATE = SETTINGS_LAYOUT["reference_rate.velocity"]  # [m/s^2]
C_W_RATE = SETTINGS_LAYOUT["reference_rate.yaw_rate"]  # [rad/s^2]
C_W_HOLD = SETTINGS_LAYOUT["reference_hold.yaw_rate"]  # [rad/s^2]
C_V_HOLD = SETTINGS_LAYOUT["reference_hold.velocity"]  # [m/s^2]
C_HOLD_CATCH_UP = SETTINGS_LAYOUT["reference_hold.catch_up"]  # [command intervals]
C_W_SMOOTHING = SETTINGS_LAYOUT["reference_smoothing.yaw_rate"]  # [s]
C_V_SMOOTHING = SETTINGS_LAYOUT["reference_smoothing.velocity"]  # [s]
C_V_JERK = SETTINGS_LAYOUT["reference_jerk.velocity"]  # [m/s^3]
C_W_JERK = SETTINGS_LAYOUT["reference_jerk.yaw_rate"]  # [rad/s^3]
C_V_RELEASE = SETTINGS_LAYOUT["collision_monitor.release_acceleration"]  # [m/s^2]
C_V_MEASUREMENT_FILTER = SETTINGS_LAYOUT["velocity.measurement_filter"]
C_W_MEASUREMENT_FILTER = SETTINGS_LAYOUT["yaw_rate.measurement_filter"]
C_CONTROLLER = SETTINGS_LAYOUT["control_law"]  # 0: the cascaded PID, 1: LQR
C_LQR = SETTINGS_LAYOUT["lqr"]  # lqr.GAIN_NAMES
C_LQR_WEIGHT = SETTINGS_LAYOUT["lqr.setpoint_weight"]
CONTROLLERS = ("pid", "lqr")
C_VELOCITY = SETTINGS_LAYOUT["velocity"]
C_PITCH = SETTINGS_LAYOUT["pitch"]
C_YAW_RATE = SETTINGS_LAYOUT["yaw_rate"]
N_SETTINGS = len(SETTINGS_LAYOUT)
# A command hold's memory (_command_hold): the last command, its stamp, whether there was one, the
# straight segment the held reference follows (from, to, start, end), whether that is a ramp, the
# smoothing's ring of the last SMOOTHING_SAMPLES held values (how many it holds, where the next goes, the
# value before the first of them), and whether the collision monitor has lowered the command since the
# shaped reference last caught up with it.
SMOOTHING_SAMPLES = 64
H_COMMAND, H_STAMP, H_HAS, H_FROM, H_TO, H_START, H_END, H_RAMP, H_COUNT, H_NEXT, H_BASE, H_LOWERED, H_RING = range(13)
N_HOLD = H_RING + SMOOTHING_SAMPLES
MAX_HOLD_INTERVAL = 0.25  # [s] commands further apart than this are not a ramp: each is held as it is
# Memory vector: the loop's state, then the three PIDs' memories (pid.MEMORY_LAYOUT each).
MEMORY_LAYOUT = Layout((
    "last_stamp", "has_last", "common_saturated", "differential_saturated", "fallen", "enabled",
    "velocity_ref_shaped", "yaw_rate_ref_shaped", "velocity_ref_slope", "yaw_rate_ref_slope", "velocity_ref_held",
    "yaw_rate_ref_held", "velocity_filtered", "yaw_rate_filtered", "filters_ready",
    ("yaw_rate_hold", N_HOLD), ("velocity_hold", N_HOLD), "lqr_position", "lqr_heading", ("velocity", N_MEMORY),
    ("pitch", N_MEMORY), ("yaw_rate", N_MEMORY),
))
K_LAST_STAMP = MEMORY_LAYOUT["last_stamp"]
K_HAS_LAST = MEMORY_LAYOUT["has_last"]
K_COMMON_SAT = MEMORY_LAYOUT["common_saturated"]
K_DIFF_SAT = MEMORY_LAYOUT["differential_saturated"]
K_FALLEN = MEMORY_LAYOUT["fallen"]
K_ENABLED = MEMORY_LAYOUT["enabled"]
K_V_SHAPED = MEMORY_LAYOUT["velocity_ref_shaped"]
K_W_SHAPED = MEMORY_LAYOUT["yaw_rate_ref_shaped"]
K_V_SLOPE = MEMORY_LAYOUT["velocity_ref_slope"]  # [m/s^2] the shaped v_ref's slope (reference_jerk)
K_W_SLOPE = MEMORY_LAYOUT["yaw_rate_ref_slope"]  # [rad/s^2]
K_V_HELD = MEMORY_LAYOUT["velocity_ref_held"]  # the held v_ref of the sample before
K_W_HELD = MEMORY_LAYOUT["yaw_rate_ref_held"]
K_V_FILTERED = MEMORY_LAYOUT["velocity_filtered"]
K_W_FILTERED = MEMORY_LAYOUT["yaw_rate_filtered"]
K_FILTERS_READY = MEMORY_LAYOUT["filters_ready"]
K_W_HOLD = MEMORY_LAYOUT["yaw_rate_hold"]
K_V_HOLD = MEMORY_LAYOUT["velocity_hold"]
K_LQR_POSITION = MEMORY_LAYOUT["lqr_position"]  # integral of the speed error [m]
K_LQR_HEADING = MEMORY_LAYOUT["lqr_heading"]  # integral of the yaw-rate error [rad]
K_VELOCITY = MEMORY_LAYOUT["velocity"]
K_PITCH = MEMORY_LAYOUT["pitch"]
K_YAW_RATE = MEMORY_LAYOUT["yaw_rate"]
N_STATE = len(MEMORY_LAYOUT)
# Output vector of one sample.
OUTPUT_LAYOUT = Layout((
    "velocity_ref", "yaw_rate_ref", "pitch_ref", "common_torque", "differential_torque", "left_torque",
    "right_torque", "dt", "pitch_ref_limited", "torque_saturated", "velocity_ref_shaped", "yaw_rate_ref_shaped",
))
O_VELOCITY_REF = OUTPUT_LAYOUT["velocity_ref"]
O_YAW_RATE_REF = OUTPUT_LAYOUT["yaw_rate_ref"]
O_PITCH_REF = OUTPUT_LAYOUT["pitch_ref"]
O_COMMON = OUTPUT_LAYOUT["common_torque"]
O_DIFFERENTIAL = OUTPUT_LAYOUT["differential_torque"]
O_LEFT = OUTPUT_LAYOUT["left_torque"]
O_RIGHT = OUTPUT_LAYOUT["right_torque"]
O_DT = OUTPUT_LAYOUT["dt"]
O_PITCH_REF_LIMITED = OUTPUT_LAYOUT["pitch_ref_limited"]
O_TORQUE_SATURATED = OUTPUT_LAYOUT["torque_saturated"]
O_V_SHAPED = OUTPUT_LAYOUT["velocity_ref_shaped"]
O_W_SHAPED = OUTPUT_LAYOUT["yaw_rate_ref_shaped"]
N_OUTPUTS = len(OUTPUT_LAYOUT)


@dataclass(frozen=True)
class ControlOutput:
    stamp: float
    velocity_ref: float
    velocity_ref_shaped: float
    velocity: float
    yaw_rate_ref: float
    yaw_rate_ref_shaped: float
    yaw_rate: float
    pitch_ref: float
    pitch: float
    pitch_rate: float
    common_torque: float
    differential_torque: float
    left_torque: float
    right_torque: float
    dt: float
    pitch_ref_limited: bool
    torque_saturated: bool
    cmd_vel_stale: bool
    fallen: bool
    enabled: bool
    pitch_estimated: bool = False  # pitch and pitch_rate came from the estimator (raw IMU)
    gyro_bias: float = 0.0  # the estimator's gyro bias about y [rad/s]
    accelerometer_pitch: float = 0.0  # the accelerometer's pitch, forward acceleration taken off [rad]
    calibrating: bool = False  # the estimator was calibrating: zero torque
    collision_limited: bool = False  # the collision monitor lowered velocity_ref (twbr_control.collision_monitor)


@inline_kernel
def _clip(value, limit):
    return min(max(value, -limit), limit)


@inline_kernel
def _copysign_int(value):
    return 1 if value >= 0.0 else -1


def settings_vector(settings: Mapping[str, Any]) -> np.ndarray:
    """The controller's validated parameters (controller_params) in the kernel's layout."""
    s = settings
    c = SETTINGS_LAYOUT.pack({**s, "period": 1.0 / s["rate"], "control_law": CONTROLLERS.index(s.get("controller", "pid"))})
    c[SETTINGS_LAYOUT.block("velocity")] = PidGains(
        s["velocity.kp"], s["velocity.ki"], s["velocity.kd"], s["velocity.derivative_filter"],
        s["max_pitch_ref"], s["velocity.setpoint_weight"],
    ).vector()
    c[SETTINGS_LAYOUT.block("pitch")] = PidGains(
        s["pitch.kp"], s["pitch.ki"], s["pitch.kd"], s["pitch.derivative_filter"], s["max_wheel_torque"],
    ).vector()
    c[SETTINGS_LAYOUT.block("yaw_rate")] = PidGains(
        s["yaw_rate.kp"], s["yaw_rate.ki"], 0.0, 0.0, s["max_wheel_torque"], s["yaw_rate.setpoint_weight"],
    ).vector()
    if c[C_CONTROLLER] == 1.0:
        from twbr_control.lqr import GAIN_NAMES, design

        gains = design(s)
        c[SETTINGS_LAYOUT.block("lqr")] = [gains[name] for name in GAIN_NAMES]
    return c


@inline_kernel
def _lqr_integral(k, slot, error, dt, unlimited_of_integral, gain, limit):
    """Integrate `error` into k[slot] unless the output -gain*integral + rest is past `limit` and the step
    pushes it further (anti-windup). Returns the output before its limit."""
    candidate = k[slot] + error * dt
    unlimited = unlimited_of_integral - gain * candidate
    if abs(unlimited) > limit and (unlimited - (unlimited_of_integral - gain * k[slot])) * unlimited > 0.0:
        return unlimited_of_integral - gain * k[slot]
    k[slot] = candidate
    return unlimited


@inline_kernel
def _lqr(c, k, velocity, yaw_rate, pitch, pitch_rate, dt):
    """The LQR law on the shaped references: (pitch_ref equivalent, common, differential, saturated flags)."""
    g = C_LQR
    limit = c[C_MAX_TORQUE]
    error_v = velocity - k[K_V_SHAPED]
    # set-point weighting as in the cascade's velocity loop: the proportional term sees b * v_ref
    rest = -(c[g + 1] * (velocity - c[C_LQR_WEIGHT] * k[K_V_SHAPED]) + c[g + 2] * (pitch - c[C_PITCH_OFFSET])
             + c[g + 3] * pitch_rate)
    unlimited = _lqr_integral(k, K_LQR_POSITION, error_v, dt, rest, c[g], limit)
    common = _clip(unlimited, limit)
    # the pitch the speed terms ask for: what the cascade would call its pitch reference
    pitch_ref = c[C_PITCH_OFFSET] - (c[g] * k[K_LQR_POSITION] + c[g + 1] * (velocity - c[C_LQR_WEIGHT] * k[K_V_SHAPED])
                                     ) / c[g + 2]
    headroom = limit - abs(common)
    error_w = yaw_rate - k[K_W_SHAPED]
    requested = _lqr_integral(k, K_LQR_HEADING, error_w, dt, -c[g + 5] * error_w, c[g + 4], headroom)
    differential = _clip(requested, headroom)
    return pitch_ref, common, differential, common != unlimited or differential != requested


@kernel
def cascade_reset(k):
    """Forget all loop memory: after a fall, a re-enable, or a jump back in time."""
    pid_reset(k[K_VELOCITY:K_PITCH])
    pid_reset(k[K_PITCH:K_YAW_RATE])
    pid_reset(k[K_YAW_RATE:])
    k[K_HAS_LAST] = 0.0
    k[K_COMMON_SAT] = 0.0
    k[K_DIFF_SAT] = 0.0
    for i in range(K_V_SHAPED, K_LQR_HEADING + 1):  # at rest after any of these: references from zero
        k[i] = 0.0


@inline_kernel
def _low_pass(k, slot, measurement, time_constant, dt):
    """First-order low-pass of a measurement into k[slot] (from the measurement itself after a reset)."""
    if time_constant <= 0.0 or k[K_FILTERS_READY] == 0.0:
        k[slot] = measurement
    else:
        k[slot] += dt / (time_constant + dt) * (measurement - k[slot])
    return k[slot]


@inline_kernel
def _segment_at(h, stamp):
    """The command hold's straight segment (H_*) at `stamp`: its end value once past its end."""
    return h[H_FROM] + (h[H_TO] - h[H_FROM]) * min(1.0, (stamp - h[H_START]) / (h[H_END] - h[H_START]))


@inline_kernel
def _command_hold(h, reference, command_stamp, stamp, max_slope, catch_up, smoothing):
    """The reference between commands (the sample-and-hold of a 20 Hz planner otherwise): on each command, a
    straight line along the stream's last slope (the change from the previous command over the interval),
    corrected by the gap between the held reference and the command spread over `catch_up` intervals. A
    stream that ramps at a slope up to `max_slope` (a planner's max_yaw_acceleration) then reaches the loop
    as the ramp itself, without lag and without steps. Where the stream's slope changes by D the line bends
    by D (1 + 1/catch_up) and then eases the gap out: with catch_up 1 (the whole gap closed within one
    interval) it bent by 2 D and back by D one interval later, a jolt of the torques where a planner reversed
    its acceleration. Bends are rounded over the last `smoothing` samples (_smoothed; 1: none). The first
    command after none starts from 0 at `max_slope` when it is within MAX_HOLD_INTERVAL's reach. A jump
    steeper than `max_slope` (a step asked for) passes at once; 0: every command held as it is. A command
    changed between two stamps (the collision monitor's limit, sample by sample) passes as it is. `h`: the
    hold's memory (H_*)."""
    if max_slope <= 0.0:
        return reference
    if h[H_HAS] == 0.0 or command_stamp > h[H_STAMP]:
        interval = command_stamp - h[H_STAMP]
        ramp = h[H_HAS] != 0.0 and 0.0 < interval <= MAX_HOLD_INTERVAL
        slope = (reference - h[H_COMMAND]) / interval if ramp else 0.0
        h[H_RAMP] = 1.0
        if ramp and abs(slope) <= max_slope * (1.0 + 1e-6):
            # along the stream's slope, closing the gap to the command over `catch_up` intervals
            start_value, duration = _segment_at(h, stamp), interval
            end_value = start_value + slope * interval - (start_value - reference) / catch_up
        elif h[H_HAS] == 0.0 and 0.0 < abs(reference) <= max_slope * MAX_HOLD_INTERVAL:
            # The first command after none (start-up, or after a stale stream): the robot was holding 0; a
            # command within one ramp's reach of it is the start of a ramp, run at max_slope from 0.
            start_value, end_value, duration = 0.0, reference, abs(reference) / max_slope
        else:  # held as it is (any duration: the segment is flat)
            start_value, end_value, duration = reference, reference, 1.0
            h[H_RAMP] = 0.0
        h[H_FROM] = start_value
        h[H_TO] = end_value
        h[H_START] = stamp
        h[H_END] = stamp + duration
        h[H_COMMAND] = reference
        h[H_STAMP] = command_stamp
        h[H_HAS] = 1.0
    elif reference != h[H_COMMAND]:
        h[H_LOWERED] = 1.0
        return _smoothed(h, reference, 1)  # changed since it came (the collision monitor lowered it): at once
    return _smoothed(h, _segment_at(h, stamp), smoothing if h[H_RAMP] != 0.0 else 1)


@inline_kernel
def _smoothed(h, value, samples):
    """The mean of the last `samples` held values, `value` the newest: a ramp's bend, where the planner's yaw
    acceleration reverses from one command to the next, reaches the loop spread over the window instead of
    as one jolt of the yaw loop's torque. samples 1: the value itself, and the window starts afresh from it,
    as if it had been held all along (a step, or a limit that applies at once)."""
    if samples <= 1:  # the ring's samples are forgotten: the window is the value until it fills again
        h[H_COUNT] = 0.0
        h[H_BASE] = value
        return value
    h[H_RING + int(h[H_NEXT])] = value
    h[H_NEXT] = (h[H_NEXT] + 1.0) % SMOOTHING_SAMPLES
    h[H_COUNT] = min(h[H_COUNT] + 1.0, SMOOTHING_SAMPLES)
    n = min(int(h[H_COUNT]), samples)
    total = (samples - n) * h[H_BASE]  # the samples before the first in the ring: the value then
    for i in range(n):
        total += h[H_RING + (int(h[H_NEXT]) - 1 - i) % SMOOTHING_SAMPLES]
    return total / samples


@inline_kernel
def _ramping(h, reference, stale):
    """Whether the hold `h` follows the planner's ramp: not a step, not stale, not lowered since it came."""
    return not stale and h[H_HAS] != 0.0 and h[H_RAMP] != 0.0 and reference == h[H_COMMAND]


@inline_kernel
def _release_rate(h, reference, held, shaped, rate, release):
    """The rate limit of v_ref this sample: `release` [m/s^2] (0: none) while it rises back in magnitude
    towards the command after the collision monitor lowered it (the monitor lets go of its limit in one
    step when the obstacle leaves the way, and under reference_rate.velocity alone the robot would lean into
    that step: |pitch| 0.045 rad), else `rate`. The hold's H_LOWERED ends once the shaped reference has
    caught up with a command the monitor no longer lowers."""
    if h[H_LOWERED] == 0.0 or release <= 0.0:
        return rate
    if held * shaped >= 0.0 and abs(held) > abs(shaped):
        return release if rate <= 0.0 else min(rate, release)
    if reference == h[H_COMMAND] and abs(held - shaped) <= 1e-9:
        h[H_LOWERED] = 0.0
    return rate


@inline_kernel
def _smoothing_samples(window, period):
    """[samples] a smoothing window [s] at the control period (at least 1: none)."""
    return max(1, min(SMOOTHING_SAMPLES, int(window / period + 0.5)))


@inline_kernel
def _rate_limit(k, shaped, reference, rate, dt):
    """Move k[shaped] towards `reference` by at most `rate` * dt (0: at once): a step becomes a ramp, a
    command stream that changes no faster (a planner's, limited by its own max_acceleration) passes as is."""
    if rate <= 0.0:
        k[shaped] = reference
    else:
        k[shaped] += _clip(reference - k[shaped], rate * dt)


@inline_kernel
def _shape(k, shaped, slope, held_before, held, rate, jerk, ramping, dt):
    """Move k[shaped] towards the held reference, its slope limited to `rate` (0: none) and the slope's change
    to `jerk` * dt (0: none) while the hold follows the planner's ramp (`ramping`) or `rate` makes a ramp of
    whatever comes. The wheel torque's change per sample is the loop's K_p times the gap between the
    reference's and the measurement's slopes: where the held reference bends (the planner reverses its turn)
    that gap is the whole bend at once, under the jerk limit at most the jerk times the loop's time constant.
    The slope goes on along the held reference's own, plus what closes the gap in the shortest time the jerk
    allows without passing it: a ramp passes without lag, a bend starts at once and is spread over bend /
    jerk seconds. Without `rate`, a step asked for, a stale command and the collision monitor's limit (not
    ramping) pass at once."""
    held_then = k[held_before]
    k[held_before] = held
    if jerk <= 0.0 or not (ramping or rate > 0.0):
        before = k[shaped]
        _rate_limit(k, shaped, held, rate, dt)
        k[slope] = (k[shaped] - before) / dt if rate > 0.0 else 0.0  # a jump is not a slope to go on along
        return
    gap = held_then - k[shaped]  # before this sample's move of the held reference
    # the slope from which steps of jerk * dt a sample down to 0 cover the gap (sqrt(2 jerk gap) in the limit)
    step = jerk * dt
    braking = 0.5 * (math.sqrt(step * step + 8.0 * jerk * abs(gap)) - step)
    wanted = (held - held_then) / dt + math.copysign(min(braking, abs(gap) / dt), gap)
    if rate > 0.0:
        wanted = _clip(wanted, rate)
    k[slope] += _clip(wanted - k[slope], step)
    k[shaped] += k[slope] * dt


@inline_kernel
def _sample_time(c, k, stamp):
    if k[K_HAS_LAST] == 0.0 or stamp <= k[K_LAST_STAMP]:
        if k[K_HAS_LAST] != 0.0:
            cascade_reset(k)  # time went backwards (a restarted simulator): start afresh
        return c[C_PERIOD]
    dt = stamp - k[K_LAST_STAMP]
    if dt > c[C_MAX_GAP]:
        for offset in (K_VELOCITY, K_PITCH, K_YAW_RATE):  # restart the derivatives
            k[offset + M_HAS_PREVIOUS] = 0.0
        return c[C_PERIOD]
    return dt


@inline_kernel
def _cascade(c, k, velocity, yaw_rate, pitch, pitch_rate, dt):
    """The paper's cascade on the shaped references: (pitch_ref, common, differential, pitch_ref limited,
    torque saturated)."""
    velocity_pid = k[K_VELOCITY:K_PITCH]
    pitch_pid = k[K_PITCH:K_YAW_RATE]
    yaw_rate_pid = k[K_YAW_RATE:]
    # The velocity loop must not wind up while the torque it asks for through the pitch loop is
    # saturated: a positive pitch_ref asks for a negative common torque first.
    pitch_ref = c[C_PITCH_OFFSET] + pid_update(
        c[C_VELOCITY:C_PITCH], velocity_pid, k[K_V_SHAPED], velocity, dt, 0.0, False, -int(k[K_COMMON_SAT]),
    )
    pitch_ref_limited = velocity_pid[M_LIMITED] != 0.0
    common = -pid_update(c[C_PITCH:C_YAW_RATE], pitch_pid, pitch_ref, pitch, dt, pitch_rate, True, 0)
    pitch_limited = pitch_pid[M_LIMITED] != 0.0
    k[K_COMMON_SAT] = _copysign_int(common) if pitch_limited else 0
    headroom = c[C_MAX_TORQUE] - abs(common)
    requested = pid_update(c[C_YAW_RATE:], yaw_rate_pid, k[K_W_SHAPED], yaw_rate, dt, 0.0, False, int(k[K_DIFF_SAT]))
    differential = _clip(requested, headroom)
    k[K_DIFF_SAT] = _copysign_int(requested) if differential != requested else 0
    return pitch_ref, common, differential, pitch_ref_limited, pitch_limited or differential != requested


@inline_kernel
def cascade_compute(c, k, out, stamp, velocity_ref, yaw_rate_ref, velocity, yaw_rate, pitch, pitch_rate,
                    cmd_vel_stale, hold, command_stamp):
    """Wheel torques for the state stamped `stamp` [s] into `out` (O_*), the references from the command stamped
    `command_stamp` [s] (a later stamp: a new command, even if equal); stale cmd_vel: zero references;
    `hold`: zero torque with the loops at rest (the estimator calibrating on the robot's stand)."""
    dt = _sample_time(c, k, stamp)
    k[K_LAST_STAMP] = stamp
    k[K_HAS_LAST] = 1.0
    if cmd_vel_stale:
        velocity_ref = 0.0
        yaw_rate_ref = 0.0
        for hold_at in (K_W_HOLD, K_V_HOLD):  # no ramp continued past the planner's silence, nor averaged
            k[hold_at + H_HAS] = 0.0
            k[hold_at + H_COUNT] = 0.0
            k[hold_at + H_BASE] = 0.0
            k[hold_at + H_LOWERED] = 0.0
    velocity_ref = _clip(velocity_ref, c[C_MAX_V_REF])
    yaw_rate_ref = _clip(yaw_rate_ref, c[C_MAX_W_REF])
    if abs(pitch - c[C_PITCH_OFFSET]) > c[C_FALL_PITCH] and k[K_FALLEN] == 0.0:
        k[K_FALLEN] = 1.0
        cascade_reset(k)
        k[K_LAST_STAMP] = stamp
        k[K_HAS_LAST] = 1.0

    pitch_ref = 0.0
    common = 0.0
    differential = 0.0
    pitch_ref_limited = False
    torque_saturated = False
    if hold:
        cascade_reset(k)
        k[K_LAST_STAMP] = stamp
        k[K_HAS_LAST] = 1.0
    elif k[K_ENABLED] != 0.0 and k[K_FALLEN] == 0.0:
        # The references are shaped before the loops see them: a cmd_vel step (each of a 20 Hz planner's
        # commands) then moves the proportional terms, and the torques, smoothly.
        # (no command: 0 at once, and the hold forgets the stream, so that the next command starts afresh)
        v_hold = k[K_V_HOLD:K_V_HOLD + N_HOLD]
        held_velocity = velocity_ref if cmd_vel_stale else _command_hold(
            v_hold, velocity_ref, command_stamp, stamp, c[C_V_HOLD], c[C_HOLD_CATCH_UP],
            _smoothing_samples(c[C_V_SMOOTHING], c[C_PERIOD]))
        _shape(k, K_V_SHAPED, K_V_SLOPE, K_V_HELD, held_velocity,
               _release_rate(v_hold, velocity_ref, held_velocity, k[K_V_SHAPED], c[C_V_RATE], c[C_V_RELEASE]),
               c[C_V_JERK], _ramping(v_hold, velocity_ref, cmd_vel_stale), dt)
        w_hold = k[K_W_HOLD:K_W_HOLD + N_HOLD]
        held_yaw_rate = yaw_rate_ref if cmd_vel_stale else _command_hold(
            w_hold, yaw_rate_ref, command_stamp, stamp, c[C_W_HOLD], c[C_HOLD_CATCH_UP],
            _smoothing_samples(c[C_W_SMOOTHING], c[C_PERIOD]))
        _shape(k, K_W_SHAPED, K_W_SLOPE, K_W_HELD, held_yaw_rate, c[C_W_RATE], c[C_W_JERK],
               _ramping(w_hold, yaw_rate_ref, cmd_vel_stale), dt)
        # Encoder speeds move in whole counts: the outer loops may see them low-passed.
        velocity = _low_pass(k, K_V_FILTERED, velocity, c[C_V_MEASUREMENT_FILTER], dt)
        yaw_rate = _low_pass(k, K_W_FILTERED, yaw_rate, c[C_W_MEASUREMENT_FILTER], dt)
        k[K_FILTERS_READY] = 1.0
        if c[C_CONTROLLER] == 1.0:
            pitch_ref, common, differential, torque_saturated = _lqr(c, k, velocity, yaw_rate, pitch, pitch_rate,
                                                                     dt)
        else:
            pitch_ref, common, differential, pitch_ref_limited, torque_saturated = _cascade(
                c, k, velocity, yaw_rate, pitch, pitch_rate, dt)
    out[O_VELOCITY_REF] = velocity_ref
    out[O_YAW_RATE_REF] = yaw_rate_ref
    out[O_PITCH_REF] = pitch_ref
    out[O_COMMON] = common
    out[O_DIFFERENTIAL] = differential
    out[O_LEFT] = _clip(common - differential, c[C_MAX_TORQUE])
    out[O_RIGHT] = _clip(common + differential, c[C_MAX_TORQUE])
    out[O_DT] = dt
    out[O_PITCH_REF_LIMITED] = 1.0 if pitch_ref_limited else 0.0
    out[O_TORQUE_SATURATED] = 1.0 if torque_saturated else 0.0
    out[O_V_SHAPED] = k[K_V_SHAPED]
    out[O_W_SHAPED] = k[K_W_SHAPED]


class CascadeController:
    """Velocity -> pitch cascade plus yaw-rate PI, with fall cut-off, enable and reset."""

    def __init__(self, settings: Mapping[str, Any], enabled: bool = True) -> None:
        self.k = np.zeros(N_STATE)
        self._out = np.zeros(N_OUTPUTS)
        self.retune(settings)
        self.k[K_ENABLED] = 1.0 if enabled else 0.0

    def retune(self, settings: Mapping[str, Any]) -> None:
        """New gains and limits from the next sample on; the loops keep their memory (no bump but the gains')."""
        c = settings_vector(settings)
        if hasattr(self, "c") and c[C_PERIOD] != self.c[C_PERIOD]:
            raise ValueError("the control rate cannot change while running")
        self.c = c
        self.period = float(c[C_PERIOD])
        self.max_torque = float(c[C_MAX_TORQUE])
        loops = ((C_VELOCITY, C_PITCH, K_VELOCITY, K_PITCH, "velocity_pid"),
                 (C_PITCH, C_YAW_RATE, K_PITCH, K_YAW_RATE, "pitch_pid"), (C_YAW_RATE, None, K_YAW_RATE, None, "yaw_rate_pid"))
        for c0, c1, k0, k1, name in loops:
            gains = PidGains(*c[c0:c1])
            if hasattr(self, name):  # the memory views stay: Pid() would reset them
                getattr(self, name).gains, getattr(self, name).g = gains, gains.vector()
            else:
                setattr(self, name, Pid(gains, self.k[k0:k1]))

    def warm_up(self) -> None:
        """Load the compiled kernel now, on a copy: from numba's cache that takes about 0.5 s, which
        the first real sample must not pay."""
        copy.deepcopy(self).compute(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @property
    def enabled(self) -> bool:
        return bool(self.k[K_ENABLED])

    @property
    def fallen(self) -> bool:
        return bool(self.k[K_FALLEN])

    def reset(self) -> None:
        cascade_reset(self.k)

    def new_run(self) -> None:
        """A new run (the clock went back: a restarted simulator, a replayed bag): the loops restart and a
        fall seen in the old run is forgotten, as the robot of the new run is upright. Enabled stays as it was."""
        self.k[K_FALLEN] = 0.0
        self.reset()

    def set_enabled(self, enabled: bool) -> None:
        """Enabling clears a fall (the user stood the robot up); either way the loops restart from zero."""
        self.k[K_ENABLED] = 1.0 if enabled else 0.0
        if enabled:
            self.k[K_FALLEN] = 0.0
        self.reset()

    def compute(
        self,
        stamp: float,
        velocity_ref: float,
        yaw_rate_ref: float,
        velocity: float,
        yaw_rate: float,
        pitch: float,
        pitch_rate: float,
        cmd_vel_stale: bool = False,
        hold: bool = False,
        command_stamp: float | None = None,
    ) -> ControlOutput:
        """Wheel torques for the state stamped `stamp` [s]; stale cmd_vel means zero references.
        `command_stamp`: when the references were commanded [s] (default `stamp`: a new command each sample)."""
        o = self._out
        cascade_compute(self.c, self.k, o, float(stamp), float(velocity_ref), float(yaw_rate_ref), float(velocity),
                        float(yaw_rate), float(pitch), float(pitch_rate), bool(cmd_vel_stale), bool(hold),
                        float(stamp if command_stamp is None else command_stamp))
        return ControlOutput(
            stamp=stamp, velocity_ref=float(o[O_VELOCITY_REF]), velocity_ref_shaped=float(o[O_V_SHAPED]),
            velocity=velocity, yaw_rate_ref=float(o[O_YAW_RATE_REF]), yaw_rate_ref_shaped=float(o[O_W_SHAPED]),
            yaw_rate=yaw_rate, pitch_ref=float(o[O_PITCH_REF]), pitch=pitch,
            pitch_rate=pitch_rate, common_torque=float(o[O_COMMON]), differential_torque=float(o[O_DIFFERENTIAL]),
            left_torque=float(o[O_LEFT]), right_torque=float(o[O_RIGHT]), dt=float(o[O_DT]),
            pitch_ref_limited=bool(o[O_PITCH_REF_LIMITED]), torque_saturated=bool(o[O_TORQUE_SATURATED]),
            cmd_vel_stale=cmd_vel_stale, fallen=self.fallen, enabled=self.enabled, calibrating=hold,
        )
