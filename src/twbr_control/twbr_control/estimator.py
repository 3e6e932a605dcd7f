"""Pitch and pitch rate from a raw IMU (gyro and accelerometer): a complementary filter with gyro-bias
estimation (the PI form of Mahony et al. 2008, reduced to the pitch axis).

The gyro's pitch rate, less the estimated bias, is integrated; the accelerometer's gravity direction pulls
the estimate back with time constant `time_constant`, and its integral, with `bias_time_constant`, is the
gyro bias. A forward acceleration tilts the measured gravity by atan(a/g): it is taken off, with a the odometry's
speed differenced. That difference is noisy (an encoder's speed moves in whole counts), but it enters only
through the filter's low-pass, which turns it into the speed's change over the time constant. The IMU is
on the axle (the contract's base_link), so the body's rotation adds no tangential acceleration.

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

SETTINGS_LAYOUT = Layout(("time_constant", "bias_time_constant", "max_gap"))
Q_TAU = SETTINGS_LAYOUT["time_constant"]
Q_TAU_BIAS = SETTINGS_LAYOUT["bias_time_constant"]  # 0: no bias estimation
Q_MAX_GAP = SETTINGS_LAYOUT["max_gap"]  # a longer gap between readings starts afresh from the accelerometer
N_SETTINGS = len(SETTINGS_LAYOUT)
MEMORY_LAYOUT = Layout(("pitch", "pitch_rate", "bias", "velocity", "last_stamp", "initialised",
                        "accel_pitch", "gyro"))
E_PITCH = MEMORY_LAYOUT["pitch"]  # [rad]
E_PITCH_RATE = MEMORY_LAYOUT["pitch_rate"]  # [rad/s]
E_BIAS = MEMORY_LAYOUT["bias"]  # gyro bias about y [rad/s]
E_VELOCITY = MEMORY_LAYOUT["velocity"]  # the last reading's odometry speed [m/s]
E_LAST_STAMP = MEMORY_LAYOUT["last_stamp"]  # [s]
E_INITIALISED = MEMORY_LAYOUT["initialised"]
E_ACCEL_PITCH = MEMORY_LAYOUT["accel_pitch"]  # the accelerometer's pitch, acceleration taken off [rad]
E_GYRO = MEMORY_LAYOUT["gyro"]  # the last reading's gyro about y [rad/s]
N_MEMORY = len(MEMORY_LAYOUT)


def settings_vector(settings: Mapping[str, Any]) -> np.ndarray:
    """From the controller's parameters (estimator.*, max_sample_gap)."""
    return SETTINGS_LAYOUT.pack({"time_constant": settings["estimator.time_constant"],
                                 "bias_time_constant": settings["estimator.bias_time_constant"],
                                 "max_gap": settings["max_sample_gap"]})


@kernel
def estimator_reset(m):
    m[:] = 0.0


@kernel
def estimator_update(q, m, stamp, gyro_y, accel_x, accel_z, velocity):
    """Take one reading stamped `stamp` [s]: gyro about y [rad/s], specific force along x and z [m/s^2], and
    the odometry's forward speed [m/s]. The estimate is m[E_PITCH], m[E_PITCH_RATE]."""
    tau = q[Q_TAU]
    dt = stamp - m[E_LAST_STAMP]
    if m[E_INITIALISED] == 0.0 or not dt > 0.0 or dt > q[Q_MAX_GAP]:
        # First reading, time going back or a gap: start from the accelerometer, keep the bias learnt.
        m[E_VELOCITY] = velocity
        m[E_PITCH] = math.atan2(-accel_x, accel_z)
        m[E_ACCEL_PITCH] = m[E_PITCH]
        m[E_INITIALISED] = 1.0
    else:
        acceleration = (velocity - m[E_VELOCITY]) / dt
        m[E_VELOCITY] = velocity
        accel_pitch = math.atan2(-accel_x, accel_z) + math.atan(acceleration / STANDARD_GRAVITY)
        m[E_ACCEL_PITCH] = accel_pitch
        predicted = m[E_PITCH] + (0.5 * (gyro_y + m[E_GYRO]) - m[E_BIAS]) * dt  # trapezoidal
        error = accel_pitch - predicted
        m[E_PITCH] = predicted + dt / (tau + dt) * error
        if q[Q_TAU_BIAS] > 0.0:
            m[E_BIAS] -= error * dt / (tau * q[Q_TAU_BIAS])
    m[E_LAST_STAMP] = stamp
    m[E_GYRO] = gyro_y
    m[E_PITCH_RATE] = gyro_y - m[E_BIAS]


class PitchEstimator:
    """One estimator: its settings and memory around the kernel."""

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
    def accelerometer_pitch(self) -> float:
        return float(self.m[E_ACCEL_PITCH])


def uses_estimator(pitch_source: str, raw_imu: bool) -> bool:
    """Whether a reading goes through the estimator: `pitch_source` (controller parameter) and whether the IMU
    reports no orientation (orientation_covariance[0] = -1)."""
    return pitch_source == "estimator" or (pitch_source == "auto" and raw_imu)
