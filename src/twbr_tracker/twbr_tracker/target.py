"""The target the planner follows, from a target detector's looks (twbr_sim.target_sensor on the simulator,
a tag-reading camera or a UWB beacon on a robot): range and bearing in the sensor's frame when it sees the
target, nothing when it does not.

A constant-velocity Kalman filter in odom (the tracks' own equations, tracks.kalman_predict and
kalman_update): each measurement is placed with the robot's pose at its instant (the sensor
`sensor_height` up the body's axis, so ahead of the axle by height x sin pitch) and fused with a variance
from the sensor's range and bearing noise at that range. Between measurements, and while the target is
hidden or out of view, it is predicted: along its velocity for at most `max_extrapolation` seconds after
the last measurement (a person or a cart does not go straight forever; the planner heads for where it was
last going), with its uncertainty growing all the while (reported as the pose's covariance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.params import ParamSpec
from twbr_tracker.tracks import N_TRACK, TR_T, TR_VX, TR_VY, TR_X, TR_Y, kalman_predict, kalman_update

TARGET_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("target.sensor_height", 0.30, "the target detector above the axle, along the body's axis (sim.yaml's"
              " target_sensor.height)", "m", 0.0, 5.0),
    ParamSpec("target.range_noise_std", 0.05, "the detector's range noise", "m", 0.0, 10.0, low_open=True),
    ParamSpec("target.bearing_noise_std", math.radians(1.0), "the detector's bearing noise", "rad", 0.0, 1.0,
              low_open=True),
    ParamSpec("target.acceleration_noise", 0.5, "spectral density of the target's white-noise acceleration",
              "m^2/s^3", 0.0, 100.0, low_open=True),
    ParamSpec("target.initial_speed_std", 0.5, "std of the target's speed before it is measured", "m/s", 0.0,
              100.0, low_open=True),
    ParamSpec("target.max_extrapolation", 2.0, "the prediction follows the velocity this long after the last"
              " measurement, then stays", "s", 0.0, 60.0),
)


@dataclass(frozen=True)
class TargetEstimate:
    x: float  # [m] in odom
    y: float
    vx: float  # [m/s]
    vy: float
    position_variance: float  # [m²], the larger axis
    since_seen: float  # [s] since the last measurement


class TargetFilter:
    def __init__(self, cfg: dict) -> None:
        self.cfg = dict(cfg)
        self.state = np.zeros(N_TRACK)
        self.cov = np.zeros((4, 4))
        self.seen: float | None = None  # stamp of the last measurement; None: never measured

    def reset(self) -> None:
        self.seen = None

    def measure(self, t: float, distance: float, bearing: float, x: float, y: float, yaw: float,
                pitch: float) -> None:
        """A measurement at t [s]: the target at `distance` [m] and `bearing` [rad] from the sensor on the robot
        at (x, y, yaw, pitch) [m, rad]."""
        cfg = self.cfg
        lean = cfg["target.sensor_height"] * math.sin(pitch)
        zx = x + lean * math.cos(yaw) + distance * math.cos(yaw + bearing)
        zy = y + lean * math.sin(yaw) + distance * math.sin(yaw + bearing)
        variance = max(cfg["target.range_noise_std"], distance * cfg["target.bearing_noise_std"]) ** 2
        if self.seen is None:
            self.state[:] = 0.0
            self.state[TR_X], self.state[TR_Y], self.state[TR_T] = zx, zy, t
            self.cov[:, :] = 0.0
            self.cov[0, 0] = self.cov[1, 1] = variance
            self.cov[2, 2] = self.cov[3, 3] = cfg["target.initial_speed_std"] ** 2
        else:
            self._predict(t)
            kalman_update(self.state, self.cov, zx, zy, variance)
        self.seen = t

    def _predict(self, t: float) -> None:
        """To t, along the velocity only up to max_extrapolation after the last measurement."""
        cfg = self.cfg
        q = cfg["target.acceleration_noise"]
        moving_until = self.seen + cfg["target.max_extrapolation"]
        if self.state[TR_T] < moving_until < t:
            kalman_predict(self.state, self.cov, moving_until, q)
        if t > moving_until:  # beyond it: the position stays, its uncertainty still grows
            vx, vy = self.state[TR_VX], self.state[TR_VY]
            self.state[TR_VX] = self.state[TR_VY] = 0.0
            kalman_predict(self.state, self.cov, t, q)
            self.state[TR_VX], self.state[TR_VY] = vx, vy
        else:
            kalman_predict(self.state, self.cov, t, q)

    def estimate(self, t: float) -> TargetEstimate | None:
        """The target at t [s] (None before its first measurement); the filter is moved to t."""
        if self.seen is None:
            return None
        self._predict(t)
        stopped = t > self.seen + self.cfg["target.max_extrapolation"]
        vx, vy = (0.0, 0.0) if stopped else (float(self.state[TR_VX]), float(self.state[TR_VY]))
        return TargetEstimate(float(self.state[TR_X]), float(self.state[TR_Y]), vx, vy,
                              float(max(self.cov[0, 0], self.cov[1, 1])), t - self.seen)
