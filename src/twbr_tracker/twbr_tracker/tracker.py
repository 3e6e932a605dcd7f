"""The tracker core as tracker_node calls it: one scan and the robot's pose in, the obstacles the planner
takes out (confirmed tracks with their velocities, and a wall's chain of discs, still)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.params import ParamSpec
from twbr_tracker.detection import DC_RADIUS, DC_WALL, DC_X, DC_Y, DETECTION_SPECS, N_DISC, detect
from twbr_tracker.detection import settings_vector as detection_vector
from twbr_tracker.tracks import (
    TR_CONFIRMED,
    TR_ID,
    TR_LOST,
    TR_MOVING,
    TR_RADIUS,
    TR_VX,
    TR_VY,
    TR_X,
    TR_Y,
    TRACK_SPECS,
    mark_occluded,
    new_tracks,
    track_step,
)
from twbr_tracker.tracks import settings_vector as track_vector

GEOMETRY_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("axle_height", 0.10, "the axle above the floor (the wheel radius)", "m", 0.0, 5.0),
    ParamSpec("lidar_height", 0.25, "the scanner above the axle, along the body's axis", "m", 0.0, 5.0),
)
TRACKER_SPECS: tuple[ParamSpec, ...] = (*GEOMETRY_SPECS, *DETECTION_SPECS, *TRACK_SPECS)
WALL_IDS = 1_000_000  # a wall disc's id: this plus its place in the chain (tracks count up from 1)


@dataclass(frozen=True)
class TrackedObstacle:
    id: int
    x: float  # [m] in odom
    y: float
    vx: float  # [m/s]
    vy: float
    radius: float  # [m]


class Tracker:
    def __init__(self, cfg: dict) -> None:
        self.cfg = dict(cfg)
        self._d = detection_vector(cfg)
        self._k = track_vector(cfg)
        self.tracks, self.cov = new_tracks(self._k)
        self.n = 0
        self.next_id = 1

    def reset(self) -> None:
        """Forget every track (the robot's odometry restarted: its old frame is gone)."""
        self.tracks[:] = 0.0
        self.cov[:] = 0.0
        self.n = 0

    def step(self, t: float, ranges: np.ndarray, angle_min: float, angle_increment: float, time_increment: float,
             x: float, y: float, yaw: float, speed: float, yaw_rate: float, pitch: float) -> list[TrackedObstacle]:
        """The scan stamped t [s] (its first beam), begun at the pose (x, y, yaw) [m, rad] moving at speed
        [m/s] and yaw_rate [rad/s], pitched by pitch [rad]: the obstacles now."""
        ranges = np.ascontiguousarray(ranges, dtype=np.float64)
        discs = np.empty((len(ranges), N_DISC))
        m = detect(self._d, ranges, angle_min, angle_increment, time_increment, x, y, yaw, speed, yaw_rate, pitch,
                   self.cfg["axle_height"], self.cfg["lidar_height"], discs)
        mark_occluded(self._k, self.tracks, self.n, t, ranges, angle_min, angle_increment, x, y, yaw)
        self.n, self.next_id = track_step(self._k, self.tracks, self.cov, self.n, self.next_id, t, discs, m)
        out = [TrackedObstacle(int(r[TR_ID]), float(r[TR_X]), float(r[TR_Y]), float(r[TR_VX]) * r[TR_MOVING],
                               float(r[TR_VY]) * r[TR_MOVING], float(r[TR_RADIUS]))
               for r in self.tracks[:self.n] if r[TR_CONFIRMED] != 0.0 and r[TR_LOST] == 0.0]
        walls = [d for d in discs[:m] if d[DC_WALL] != 0.0]
        out += [TrackedObstacle(WALL_IDS + k, float(d[DC_X]), float(d[DC_Y]), 0.0, 0.0, float(d[DC_RADIUS]))
                for k, d in enumerate(walls)]
        return out

    def warm_up(self) -> None:
        """Load the compiled kernels now, on a copy, so the first scan is answered on time."""
        twin = Tracker(self.cfg)
        ranges = np.full(360, math.inf)
        ranges[170:190] = 2.0
        for t in (0.0, 0.1):
            twin.step(t, ranges, -math.pi, math.radians(1.0), 1.0 / 3600.0, 0.0, 0.0, 0.0, 0.1, 0.1, 0.0)
