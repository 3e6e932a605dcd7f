"""Pitch and pitch rate from a raw IMU (gyro and accelerometer): a complementary filter with gyro-bias
estimation (the PI form of Mahony et al. 2008, reduced to the pitch axis); and the forward speed, the
encoders' (which moves in whole counts) fused with the accelerometer's (smooth, drifting) by a second one.

For its first `calibration_time` the robot stands still on its stand (a robot's start-up calibration; the
controller holds zero torque meanwhile): the gyro's mean reading is its bias, the accelerometer's its
pitch. Then the gyro's pitch rate, less the bias, is integrated; the accelerometer's gravity direction pulls
the estimate back with time constant `time_constant`, and its integral, with `bias_time_constant`, keeps
the bias up to date. A forward acceleration tilts the measured gravity by atan(a/g): it is taken off, with
a the odometry's speed differenced through a short low-pass (ACCELERATION_FILTER). The IMU is on the axle
(the contract's base_link), so the body's rotation adds no tangential acceleration.

`estimator_update` is the one implementation: the controller node, the headless closed loop and the batch
engine call it on a settings vector (Q_*) and a memory vector (E_*).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout

STANDARD_GRAVITY = 9.80665  # [m/s^2] only the forward-acceleration term uses it: atan(a/g)
# [s] the odometry's speed is differenced through a low-pass this long: an encoder's speed moves in steps of
# a count per window, which differenced sample by sample would read as m/s^2 spikes (0.015 m/s in 5 ms);
# longer lags the correction in a manoeuvre (0.05 s: 40 % overshoot on the realistic step against 30 %)
ACCELERATION_FILTER = 0.02
STILL_RATE = 0.05  # [rad/s] a calibration reading further from the gyro's mean than this is motion
STILL_PITCH = 0.05  # [rad] the same for the accelerometer's pitch

SETTINGS_LAYOUT = Layout(("time_constant", "bias_time_constant", "max_gap", "velocity_time_constant",
                          "calibration_time"))
ES_TAU = SETTINGS_LAYOUT["time_constant"]
ES_TAU_BIAS = SETTINGS_LAYOUT["bias_time_constant"]  # 0: no bias estimation
ES_MAX_GAP = SETTINGS_LAYOUT["max_gap"]  # a longer gap between readings starts afresh from the accelerometer
ES_TAU_VELOCITY = SETTINGS_LAYOUT["velocity_time_constant"]  # 0: the odometry's speed as it is
ES_CALIBRATION = SETTINGS_LAYOUT["calibration_time"]  # [s] the gyro bias is the mean reading this long at start
N_SETTINGS = len(SETTINGS_LAYOUT)
MEMORY_LAYOUT = Layout(("pitch", "pitch_rate", "bias", "velocity", "last_stamp", "initialised",
                        "accel_pitch", "gyro", "velocity_estimate", "calibration_elapsed", "calibration_readings",
                        "calibrating"))
E_PITCH = MEMORY_LAYOUT["pitch"]  # [rad]
E_PITCH_RATE = MEMORY_LAYOUT["pitch_rate"]  # [rad/s]
E_BIAS = MEMORY_LAYOUT["bias"]  # gyro bias about y [rad/s]
E_VELOCITY = MEMORY_LAYOUT["velocity"]  # the odometry's speed, low-passed (ACCELERATION_FILTER) [m/s]
E_LAST_STAMP = MEMORY_LAYOUT["last_stamp"]  # [s]
E_INITIALISED = MEMORY_LAYOUT["initialised"]
E_ACCEL_PITCH = MEMORY_LAYOUT["accel_pitch"]  # the accelerometer's pitch, acceleration taken off [rad]
E_GYRO = MEMORY_LAYOUT["gyro"]  # the last reading's gyro about y [rad/s]
E_VELOCITY_ESTIMATE = MEMORY_LAYOUT["velocity_estimate"]  # forward speed, odometry and accelerometer fused [m/s]
E_CALIBRATION_ELAPSED = MEMORY_LAYOUT["calibration_elapsed"]  # [s] since the first reading
E_CALIBRATION_READINGS = MEMORY_LAYOUT["calibration_readings"]
E_CALIBRATING = MEMORY_LAYOUT["calibrating"]  # the controller holds zero torque meanwhile
N_MEMORY = len(MEMORY_LAYOUT)


def settings_vector(settings: Mapping[str, Any]) -> np.ndarray:
    """From the controller's parameters (estimator.*, max_sample_gap)."""
    return SETTINGS_LAYOUT.pack({"time_constant": settings["estimator.time_constant"],
                                 "bias_time_constant": settings["estimator.bias_time_constant"],
                                 "max_gap": settings["max_sample_gap"],
                                 "velocity_time_constant": settings["estimator.velocity_time_constant"],
                                 "calibration_time": settings["estimator.calibration_time"]})


@kernel
def estimator_reset(m):
    m[:] = 0.0


@kernel
def estimator_update(q, m, stamp, gyro_y, accel_x, accel_z, velocity):
    """Take one reading stamped `stamp` [s]: gyro about y [rad/s], specific force along x and z [m/s^2], and
    the odometry's forward speed [m/s]. The estimate is m[E_PITCH], m[E_PITCH_RATE]."""
    tau = q[ES_TAU]
    dt = stamp - m[E_LAST_STAMP]
    if m[E_INITIALISED] == 0.0 or not dt > 0.0 or dt > q[ES_MAX_GAP]:
        # First reading, time going back or a gap: start from the accelerometer, keep the bias learnt.
        m[E_VELOCITY] = velocity
        m[E_PITCH] = math.atan2(-accel_x, accel_z)
        m[E_ACCEL_PITCH] = m[E_PITCH]
        m[E_VELOCITY_ESTIMATE] = velocity
        if m[E_INITIALISED] == 0.0 and q[ES_CALIBRATION] > 0.0:  # only at start, never after a gap
            m[E_BIAS] = gyro_y
            m[E_CALIBRATION_READINGS] = 1.0
            m[E_CALIBRATING] = 1.0
        m[E_INITIALISED] = 1.0
    elif m[E_CALIBRATING] != 0.0:
        # Standing still on its stand: the gyro's mean reading is its bias, the accelerometer's mean pitch
        # its pitch. A reading that moves ends the calibration early (a controller restarted on a robot
        # that is already balancing must not wait): the bias is then left to the filter.
        n = m[E_CALIBRATION_READINGS] + 1.0
        accel_pitch = math.atan2(-accel_x, accel_z)
        if abs(gyro_y - m[E_BIAS]) > STILL_RATE or abs(accel_pitch - m[E_PITCH]) > STILL_PITCH:
            m[E_CALIBRATING] = 0.0
            if n < 3.0:
                m[E_BIAS] = 0.0
        else:
            m[E_CALIBRATION_READINGS] = n
            m[E_BIAS] += (gyro_y - m[E_BIAS]) / n
            m[E_PITCH] += (accel_pitch - m[E_PITCH]) / n
            m[E_ACCEL_PITCH] = accel_pitch
            m[E_CALIBRATION_ELAPSED] += dt
            if m[E_CALIBRATION_ELAPSED] >= q[ES_CALIBRATION]:
                m[E_CALIBRATING] = 0.0
    else:
        m[E_VELOCITY] += dt / (ACCELERATION_FILTER + dt) * (velocity - m[E_VELOCITY])
        acceleration = (velocity - m[E_VELOCITY]) / ACCELERATION_FILTER  # the speed's low-passed derivative
        accel_pitch = math.atan2(-accel_x, accel_z) + math.atan(acceleration / STANDARD_GRAVITY)
        m[E_ACCEL_PITCH] = accel_pitch
        predicted = m[E_PITCH] + (0.5 * (gyro_y + m[E_GYRO]) - m[E_BIAS]) * dt  # trapezoidal
        error = accel_pitch - predicted
        m[E_PITCH] = predicted + dt / (tau + dt) * error
        if q[ES_TAU_BIAS] > 0.0:
            m[E_BIAS] -= error * dt / (tau * q[ES_TAU_BIAS])
        # Speed: the accelerometer's forward acceleration (its specific force turned level by the pitch)
        # integrated, pulled to the odometry's speed with its own time constant.
        # (An accelerometer bias b leaves it b * tau_v off: 5 mm/s for 5 mg at 0.1 s, inside the loop's 2 %.)
        tau_v = q[ES_TAU_VELOCITY]
        if tau_v > 0.0:
            pitch = m[E_PITCH]
            forward = accel_x * math.cos(pitch) + accel_z * math.sin(pitch)
            estimate = m[E_VELOCITY_ESTIMATE] + forward * dt
            m[E_VELOCITY_ESTIMATE] = estimate + dt / (tau_v + dt) * (velocity - estimate)
        else:
            m[E_VELOCITY_ESTIMATE] = velocity
    m[E_LAST_STAMP] = stamp
    m[E_GYRO] = gyro_y
    m[E_PITCH_RATE] = gyro_y - m[E_BIAS]


class PitchEstimator:
    """One estimator: its settings and memory around the kernel."""

    @property
    def velocity(self) -> float:
        """The forward speed for the velocity loop [m/s]: the odometry's, or fused with the accelerometer."""
        return float(self.m[E_VELOCITY_ESTIMATE])

    def __init__(self, settings: Mapping[str, Any]) -> None:
        self.q = settings_vector(settings)
        self.m = np.zeros(N_MEMORY)

    def reset(self) -> None:
        estimator_reset(self.m)

    def update(self, stamp: float, gyro_y: float, accel_x: float, accel_z: float, velocity: float) -> tuple[float, float]:
        """(pitch [rad], pitch rate [rad/s]) after the reading stamped `stamp` [s]."""
        estimator_update(self.q, self.m, float(stamp), float(gyro_y), float(accel_x), float(accel_z), float(velocity))
        return float(self.m[E_PITCH]), float(self.m[E_PITCH_RATE])

    @property
    def bias(self) -> float:
        return float(self.m[E_BIAS])

    @property
    def calibrating(self) -> bool:
        """Still calibrating at start-up: the controller holds zero torque."""
        return bool(self.m[E_CALIBRATING])

    @property
    def accelerometer_pitch(self) -> float:
        return float(self.m[E_ACCEL_PITCH])


def uses_estimator(pitch_source: str, raw_imu: bool) -> bool:
    """Whether a reading goes through the estimator: `pitch_source` (controller parameter) and whether the IMU
    reports no orientation (orientation_covariance[0] = -1)."""
    return pitch_source == "estimator" or (pitch_source == "auto" and raw_imu)
