"""The tracker core as tracker_node calls it: one scan and the robot's pose in, the obstacles the planner
takes out (confirmed tracks with their velocities, and a wall's chain of discs, still)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.lidar import scanner_at
from twbr_tracker.detection import DETECTION_SPECS, N_DISC, detect
from twbr_tracker.detection import settings_vector as detection_vector
from twbr_tracker.surfaces import SURFACE_SPECS, mark_still, new_surfaces, remember_scan
from twbr_tracker.surfaces import settings_vector as surface_vector
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
    TS_MAX_TRACKS,
    mark_occluded,
    new_tracks,
    track_step,
)
from twbr_tracker.tracks import settings_vector as track_vector
from twbr_tracker.wall_memory import N_WALL, WALL_MEMORY_SPECS, WL_RADIUS, WL_X, WL_Y, WM_MAX_DISCS, remember_walls
from twbr_tracker.wall_memory import settings_vector as wall_vector

GEOMETRY_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("axle_height", 0.10, "the axle above the floor (the wheel radius)", "m", 0.0, 5.0),
    ParamSpec("lidar_height", 0.25, "the scanner above the axle, along the body's axis", "m", 0.0, 5.0),
)
TRACKER_SPECS: tuple[ParamSpec, ...] = (*GEOMETRY_SPECS, *DETECTION_SPECS, *TRACK_SPECS, *WALL_MEMORY_SPECS,
                                        *SURFACE_SPECS)
WALL_IDS = 1_000_000  # a wall disc's id: this plus its place in the chain (tracks count up from 1)
# The tracker's output, one row per obstacle, as the planner reads an ObstacleArray (twbr_common.cdr's rows):
OBSTACLE_ROW = Layout(("id", "x", "y", "vx", "vy", "radius"))  # [m, m/s] in odom
N_OBSTACLE_ROW = len(OBSTACLE_ROW)
# What a tracker carries between scans besides its tracks and remembered walls: the tracks' count, the
# next track's id and the remembered wall discs' count.
K_COUNT = 0
K_NEXT_ID = 1
K_WALLS = 2
N_COUNTERS = 3


@dataclass(frozen=True)
class TrackedObstacle:
    id: int
    x: float  # [m] in odom
    y: float
    vx: float  # [m/s]
    vy: float
    radius: float  # [m]


@kernel
def tracker_scan(d, k, w, u, tracks, cov, walls, surfaces, counters, t, ranges, angle_min, angle_increment,
                 time_increment, x, y, yaw, speed, yaw_rate, pitch, axle_height, lidar_height, discs, points, out):
    """The scan stamped t [s] (its first beam), begun at the pose (x, y, yaw) [m, rad] moving at speed [m/s]
    and yaw_rate [rad/s], pitched by pitch [rad]: the obstacles now into out's rows (OBSTACLE_ROW: the
    confirmed live tracks, static ones still, then the walls' discs, seen now or remembered:
    wall_memory); returns their count. `discs` and `points` are scratch of at least one row per beam (as
    detect takes them)."""
    m = detect(d, ranges, angle_min, angle_increment, time_increment, x, y, yaw, speed, yaw_rate, pitch,
               axle_height, lidar_height, discs, points)
    mark_still(u, surfaces, points, discs, m)
    n = int(counters[K_COUNT])
    mark_occluded(k, tracks, n, t, ranges, angle_min, angle_increment, x, y, yaw)
    n, next_id = track_step(k, tracks, cov, n, int(counters[K_NEXT_ID]), t, discs, m)
    counters[K_COUNT] = n
    counters[K_NEXT_ID] = next_id
    sx, sy, _heading = scanner_at(x, y, yaw, speed, yaw_rate, 0.0, lidar_height * math.sin(pitch))  # as detect's
    kept = remember_walls(w, walls, int(counters[K_WALLS]), t, discs, m, ranges, angle_min, angle_increment, sx, sy,
                          yaw)
    remember_scan(u, surfaces, t, points, ranges, angle_min, angle_increment, time_increment, yaw, yaw_rate, sx, sy)
    counters[K_WALLS] = kept
    rows = 0
    for i in range(n):
        if tracks[i, TR_CONFIRMED] != 0.0 and tracks[i, TR_LOST] == 0.0 and rows < out.shape[0]:
            out[rows, 0] = tracks[i, TR_ID]
            out[rows, 1] = tracks[i, TR_X]
            out[rows, 2] = tracks[i, TR_Y]
            out[rows, 3] = tracks[i, TR_VX] * tracks[i, TR_MOVING]
            out[rows, 4] = tracks[i, TR_VY] * tracks[i, TR_MOVING]
            out[rows, 5] = tracks[i, TR_RADIUS]
            rows += 1
    for i in range(kept):
        if rows < out.shape[0]:
            out[rows, 0] = WALL_IDS + i
            out[rows, 1] = walls[i, WL_X]
            out[rows, 2] = walls[i, WL_Y]
            out[rows, 3] = 0.0
            out[rows, 4] = 0.0
            out[rows, 5] = walls[i, WL_RADIUS]
            rows += 1
    return rows


@kernel
def output_rows(k, w):
    """Rows enough for any scan's output: every track and every remembered wall disc."""
    return int(k[TS_MAX_TRACKS]) + int(w[WM_MAX_DISCS])


def new_walls(w: np.ndarray) -> np.ndarray:
    """An empty wall memory (WALL_LAYOUT rows)."""
    return np.zeros((int(w[WM_MAX_DISCS]), N_WALL))


class Tracker:
    def __init__(self, cfg: dict) -> None:
        self.cfg = dict(cfg)
        self._d = detection_vector(cfg)
        self._k = track_vector(cfg)
        self._w = wall_vector(cfg)
        self._u = surface_vector(cfg)
        self.tracks, self.cov = new_tracks(self._k)
        self.walls = new_walls(self._w)
        self.surfaces = new_surfaces()
        self.counters = np.zeros(N_COUNTERS)
        self.reset()

    @property
    def n(self) -> int:
        return int(self.counters[K_COUNT])

    def reset(self) -> None:
        """Forget every track (the robot's odometry restarted: its old frame is gone); ids count on."""
        self.tracks[:] = 0.0
        self.cov[:] = 0.0
        self.counters[K_COUNT] = 0
        self.counters[K_WALLS] = 0
        self.surfaces[:] = math.nan
        self.counters[K_NEXT_ID] = max(self.counters[K_NEXT_ID], 1)

    def step(self, t: float, ranges: np.ndarray, angle_min: float, angle_increment: float, time_increment: float,
             x: float, y: float, yaw: float, speed: float, yaw_rate: float, pitch: float) -> list[TrackedObstacle]:
        """The scan stamped t [s] (its first beam), begun at the pose (x, y, yaw) [m, rad] moving at speed
        [m/s] and yaw_rate [rad/s], pitched by pitch [rad]: the obstacles now."""
        return [TrackedObstacle(int(r[0]), float(r[1]), float(r[2]), float(r[3]), float(r[4]), float(r[5]))
                for r in self.step_rows(t, ranges, angle_min, angle_increment, time_increment, x, y, yaw, speed,
                                        yaw_rate, pitch)]

    def step_rows(self, t: float, ranges: np.ndarray, angle_min: float, angle_increment: float,
                  time_increment: float, x: float, y: float, yaw: float, speed: float, yaw_rate: float,
                  pitch: float) -> np.ndarray:
        """`step`'s obstacles as the kernel leaves them: rows of OBSTACLE_ROW."""
        ranges = np.ascontiguousarray(ranges, dtype=np.float64)
        discs = np.empty((len(ranges), N_DISC))
        points = np.empty((len(ranges), 2))
        out = np.empty((output_rows(self._k, self._w), N_OBSTACLE_ROW))
        rows = tracker_scan(self._d, self._k, self._w, self._u, self.tracks, self.cov, self.walls, self.surfaces,
                            self.counters, t, ranges, angle_min, angle_increment, time_increment, x, y, yaw, speed,
                            yaw_rate, pitch, self.cfg["axle_height"], self.cfg["lidar_height"], discs, points, out)
        return out[:rows]

    def warm_up(self) -> None:
        """Load the compiled kernels now, on a copy, so the first scan is answered on time."""
        twin = Tracker(self.cfg)
        ranges = np.full(360, math.inf)
        ranges[170:190] = 2.0
        for t in (0.0, 0.1):
            twin.step(t, ranges, -math.pi, math.radians(1.0), 1.0 / 3600.0, 0.0, 0.0, 0.0, 0.1, 0.1, 0.0)
