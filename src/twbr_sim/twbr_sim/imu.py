"""What an IMU on the axle centre, aligned with base_link, would report: orientation, body rates and
specific force including gravity, with optional seeded white noise and constant bias.

base_link is pitched with the body (roll 0, pitch theta, yaw psi), so its x axis tips forward-down
when the body leans forward. Noise is off by default so that the ideal sensor is the baseline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.params import ParamSpec
from twbr_sim.dynamics import S_PSI, S_PSID, S_TH, S_THD, S_XD
from twbr_sim.robot_params import P_G

IMU_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("imu.gyro_noise_std", 0.0, "white noise on each angular rate", "rad/s", 0.0, 10.0),
    ParamSpec("imu.gyro_bias_std", 0.0, "std of the constant gyro bias drawn at start-up", "rad/s", 0.0, 10.0),
    ParamSpec("imu.accel_noise_std", 0.0, "white noise on each specific-force axis", "m/s^2", 0.0, 100.0),
    ParamSpec("imu.accel_bias_std", 0.0, "std of the constant accelerometer bias drawn at start-up", "m/s^2", 0.0, 100.0),
    ParamSpec("imu.orientation_noise_std", 0.0, "white noise on roll, pitch and yaw of the orientation", "rad", 0.0, 1.0),
    ParamSpec("imu.pitch_bias", 0.0, "constant pitch offset of the mounting (a miscalibrated IMU)", "rad", -0.5, 0.5),
)


@dataclass
class ImuReading:
    roll: float
    pitch: float
    yaw: float
    angular_velocity: tuple[float, float, float]
    linear_acceleration: tuple[float, float, float]


def ideal_reading(p: np.ndarray, s: np.ndarray, ds: np.ndarray) -> ImuReading:
    """Noise-free reading from state `s` and its derivative `ds` (for the accelerations)."""
    pitch, yaw = s[S_TH], s[S_PSI]
    sn, cs = math.sin(pitch), math.cos(pitch)
    yaw_rate = s[S_PSID]
    # Body rates: the yaw rate is about world z, which in the pitched body frame is (-sin, 0, cos).
    gyro = (-sn * yaw_rate, s[S_THD], cs * yaw_rate)
    # Specific force of the axle centre in the heading frame: forward accel, centripetal, +g;
    # then rotated into the pitched body frame.
    g = p[P_G]
    a_fwd = ds[S_XD]
    a_lat = s[S_XD] * yaw_rate
    accel = (cs * a_fwd - sn * g, a_lat, sn * a_fwd + cs * g)
    return ImuReading(0.0, pitch, yaw, gyro, accel)


class ImuModel:
    """Adds seeded noise and bias to the ideal reading."""

    def __init__(self, settings: dict[str, float], seed: int) -> None:
        self._rng = np.random.default_rng(seed)
        self.gyro_noise = settings["imu.gyro_noise_std"]
        self.accel_noise = settings["imu.accel_noise_std"]
        self.orientation_noise = settings["imu.orientation_noise_std"]
        self.pitch_bias = settings["imu.pitch_bias"]
        self.gyro_bias = self._rng.normal(0.0, 1.0, 3) * settings["imu.gyro_bias_std"]
        self.accel_bias = self._rng.normal(0.0, 1.0, 3) * settings["imu.accel_bias_std"]

    @property
    def noisy(self) -> bool:
        return bool(self.gyro_noise or self.accel_noise or self.orientation_noise)

    def read(self, p: np.ndarray, s: np.ndarray, ds: np.ndarray) -> ImuReading:
        ideal = ideal_reading(p, s, ds)
        gyro = np.asarray(ideal.angular_velocity) + self.gyro_bias
        accel = np.asarray(ideal.linear_acceleration) + self.accel_bias
        rpy = np.array([ideal.roll, ideal.pitch + self.pitch_bias, ideal.yaw])
        if self.noisy:
            gyro = gyro + self._rng.normal(0.0, self.gyro_noise, 3)
            accel = accel + self._rng.normal(0.0, self.accel_noise, 3)
            rpy = rpy + self._rng.normal(0.0, self.orientation_noise, 3)
        return ImuReading(
            float(rpy[0]), float(rpy[1]), float(rpy[2]),
            (float(gyro[0]), float(gyro[1]), float(gyro[2])),
            (float(accel[0]), float(accel[1]), float(accel[2])),
        )
