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

Before the first measurement the target is where the mission says it starts (`target.prior_x`, `prior_y`,
with `prior_std`: a goal handed to the robot, as a user would give a tag's last known place), standing
still with its uncertainty growing; with `prior_std` 0 there is no prior and the target is unknown until
it is first seen (the planner then stands). The first measurement replaces the prior outright: a prior
that the target has long walked away from must not pull the first estimates back towards it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
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
    ParamSpec("target.prior_x", 0.0, "where the target is before its first measurement (with prior_std > 0)",
              "m", -1e6, 1e6),
    ParamSpec("target.prior_y", 0.0, "where the target is before its first measurement (with prior_std > 0)",
              "m", -1e6, 1e6),
    ParamSpec("target.prior_std", 0.0, "std of the prior's position (0: no prior, the target is unknown until"
              " first seen)", "m", 0.0, 1e3),
)


# [m] the std of a target's start handed over as a mission's goal (the runner's and the batch engine's
# target.prior_std: a scenario's start is exact; a user's would be a few cm off)
MISSION_PRIOR_STD = 0.1

SETTINGS_LAYOUT = Layout(("sensor_height", "range_noise_std", "bearing_noise_std", "acceleration_noise",
                          "initial_speed_std", "max_extrapolation", "prior_x", "prior_y", "prior_std"))
TG_SENSOR_HEIGHT = SETTINGS_LAYOUT["sensor_height"]
TG_RANGE_NOISE = SETTINGS_LAYOUT["range_noise_std"]
TG_BEARING_NOISE = SETTINGS_LAYOUT["bearing_noise_std"]
TG_ACCELERATION_NOISE = SETTINGS_LAYOUT["acceleration_noise"]
TG_INITIAL_SPEED_STD = SETTINGS_LAYOUT["initial_speed_std"]
TG_MAX_EXTRAPOLATION = SETTINGS_LAYOUT["max_extrapolation"]
TG_PRIOR_X = SETTINGS_LAYOUT["prior_x"]
TG_PRIOR_Y = SETTINGS_LAYOUT["prior_y"]
TG_PRIOR_STD = SETTINGS_LAYOUT["prior_std"]
N_SETTINGS = len(SETTINGS_LAYOUT)

# The filter's memory: a track's columns (tracks.TRACK_LAYOUT: x, y, vx, vy at TR_T), then the stamp of
# the last measurement and the first instant the prior was asked at (NaN: none yet).
TG_SEEN = N_TRACK
TG_PRIOR_FROM = N_TRACK + 1
N_MEMORY = N_TRACK + 2
# An estimate: position [m], velocity [m/s], the position's variance [m²] (the larger axis), the time since
# the last measurement [s] (inf: the prior only).
ESTIMATE_LAYOUT = Layout(("x", "y", "vx", "vy", "position_variance", "since_seen"))
N_ESTIMATE = len(ESTIMATE_LAYOUT)


def settings_vector(cfg: dict) -> np.ndarray:
    """The kernels' settings from validated `target.*` parameters."""
    return SETTINGS_LAYOUT.pack({name: cfg[f"target.{name}"] for name in SETTINGS_LAYOUT.names})


@kernel
def target_begin(memory, cov):
    """Nothing measured yet, the prior not yet asked for."""
    memory[:] = 0.0
    cov[:, :] = 0.0
    memory[TG_SEEN] = math.nan
    memory[TG_PRIOR_FROM] = math.nan


@kernel
def target_measure(s, memory, cov, t, distance, bearing, x, y, yaw, pitch):
    """A measurement at t [s]: the target at `distance` [m] and `bearing` [rad] from the sensor on the robot
    at (x, y, yaw, pitch) [m, rad]."""
    lean = s[TG_SENSOR_HEIGHT] * math.sin(pitch)
    zx = x + lean * math.cos(yaw) + distance * math.cos(yaw + bearing)
    zy = y + lean * math.sin(yaw) + distance * math.sin(yaw + bearing)
    variance = max(s[TG_RANGE_NOISE], distance * s[TG_BEARING_NOISE]) ** 2
    if math.isnan(memory[TG_SEEN]):  # the first: it replaces the prior outright
        memory[:N_TRACK] = 0.0
        memory[TR_X] = zx
        memory[TR_Y] = zy
        memory[TR_T] = t
        cov[:, :] = 0.0
        cov[0, 0] = variance
        cov[1, 1] = variance
        cov[2, 2] = s[TG_INITIAL_SPEED_STD] ** 2
        cov[3, 3] = s[TG_INITIAL_SPEED_STD] ** 2
    else:
        _predict(s, memory, cov, t)
        kalman_update(memory, cov, zx, zy, variance)
    memory[TG_SEEN] = t


@kernel
def _predict(s, memory, cov, t):
    """To t, along the velocity only up to max_extrapolation after the last measurement."""
    q = s[TG_ACCELERATION_NOISE]
    moving_until = memory[TG_SEEN] + s[TG_MAX_EXTRAPOLATION]
    if memory[TR_T] < moving_until < t:
        kalman_predict(memory, cov, moving_until, q)
    if t > moving_until:  # beyond it: the position stays, its uncertainty still grows
        vx = memory[TR_VX]
        vy = memory[TR_VY]
        memory[TR_VX] = 0.0
        memory[TR_VY] = 0.0
        kalman_predict(memory, cov, t, q)
        memory[TR_VX] = vx
        memory[TR_VY] = vy
    else:
        kalman_predict(memory, cov, t, q)


@kernel
def target_estimate(s, memory, cov, t, out):
    """The target at t [s] into `out` (ESTIMATE_LAYOUT); the filter is moved to t. Before the first
    measurement: the prior, standing where it was given, its variance growing from the first instant asked
    as the filter's own would (position, and a speed of initial_speed_std, uncorrelated). False: unknown
    (no measurement and no prior)."""
    if math.isnan(memory[TG_SEEN]):
        if s[TG_PRIOR_STD] <= 0.0:
            return False
        if math.isnan(memory[TG_PRIOR_FROM]):
            memory[TG_PRIOR_FROM] = t
        dt = t - memory[TG_PRIOR_FROM]
        out[0] = s[TG_PRIOR_X]
        out[1] = s[TG_PRIOR_Y]
        out[2] = 0.0
        out[3] = 0.0
        out[4] = (s[TG_PRIOR_STD] ** 2 + (s[TG_INITIAL_SPEED_STD] * dt) ** 2
                  + s[TG_ACCELERATION_NOISE] * dt ** 3 / 3.0)
        out[5] = math.inf
        return True
    _predict(s, memory, cov, t)
    stopped = t > memory[TG_SEEN] + s[TG_MAX_EXTRAPOLATION]
    out[0] = memory[TR_X]
    out[1] = memory[TR_Y]
    out[2] = 0.0 if stopped else memory[TR_VX]
    out[3] = 0.0 if stopped else memory[TR_VY]
    out[4] = max(cov[0, 0], cov[1, 1])
    out[5] = t - memory[TG_SEEN]
    return True


@dataclass(frozen=True)
class TargetEstimate:
    x: float  # [m] in odom
    y: float
    vx: float  # [m/s]
    vy: float
    position_variance: float  # [m²], the larger axis
    since_seen: float  # [s] since the last measurement (inf: only the prior so far)


class TargetFilter:
    """The filter as tracker_node calls it (the batch engine calls its kernels on rows of its own)."""

    def __init__(self, cfg: dict) -> None:
        self.cfg = dict(cfg)
        self._s = settings_vector(cfg)
        self.memory = np.zeros(N_MEMORY)
        self.cov = np.zeros((4, 4))
        self._out = np.zeros(N_ESTIMATE)
        self.reset()

    def reset(self) -> None:
        """Forget every measurement (not the prior: it is the mission's)."""
        target_begin(self.memory, self.cov)

    def measure(self, t: float, distance: float, bearing: float, x: float, y: float, yaw: float,
                pitch: float) -> None:
        target_measure(self._s, self.memory, self.cov, t, distance, bearing, x, y, yaw, pitch)

    def estimate(self, t: float) -> TargetEstimate | None:
        """The target at t [s] (before its first measurement: the prior, or None without one)."""
        if not target_estimate(self._s, self.memory, self.cov, t, self._out):
            return None
        return TargetEstimate(*(float(v) for v in self._out))
