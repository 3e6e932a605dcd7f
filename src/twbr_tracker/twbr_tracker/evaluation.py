"""How well the tracks follow the world: issue 36's tracker figures, from a run's obstacle lists.

At every instant that has both a track list (tracker_node's `obstacles`) and the world's own list (the
simulator's, remapped to `obstacles_truth` by the runner), the tracks are matched one to one to the world's
obstacles by the Hungarian method on the distance between centres, within `gate` (the tracker's own
assignment kernel), after each obstacle has kept the track it was last matched to if that track is still
within `gate` of it (CLEAR-MOT's correspondence rule: people passing through each other are not switches
because the nearest track changed for a moment). Walls' discs (ids from WALL_IDS) are the wall's, not
tracks, and are left out.
Judged on the world's moving obstacles that are *visible*: within `range_max` of the robot and with no
other obstacle's disc across the line from the robot to their centre (CLEAR-MOT's rules, Bernardin &
Stiefelhagen 2008, on our discs):

- position and velocity RMSE of the matched pairs whose track is older than `settle` (a track's first
  second is its filter's start);
- ID switches: a visible obstacle matched to another track than the one it was last matched to;
- missed: a visible moving obstacle without a track; false: a track matched to no obstacle at all;
- per 100 track-seconds: ID switches over the time the matched tracks existed.

A track's age counts from the first list that carries its id since it was last missing from one (a track
dropped and taken back restarts its filter's first second). `judge_lists` is the one judging step, compiled:
the batch engine calls it at every scan of every robot (its suite table's tracker figures), `evaluate` at
every instant of a graph run's recording (metrics.json).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_tracker.assignment import assign
from twbr_tracker.tracker import WALL_IDS

# Rows of an obstacle list: id, x, y, vx, vy, radius (twbr_common.cdr.obstacle_rows)
OB_ID, OB_X, OB_Y, OB_VX, OB_VY, OB_RADIUS = range(6)
MOVING = 0.05  # [m/s] an obstacle slower than this is standing (a person waiting is not judged on velocity)
GATE = 0.5  # [m] a track further than this from an obstacle's centre is not on it
SETTLE = 1.0  # [s] a track's first second is its filter's start: not judged on error

# What judging a run adds up, list after list (judge_lists)
JUDGE_LAYOUT = Layout(("instants", "judged", "matched", "settled", "position_square_sum", "velocity_square_sum",
                       "id_switches", "missed", "false_tracks", "tracks"))
JG_INSTANTS = JUDGE_LAYOUT["instants"]
JG_JUDGED = JUDGE_LAYOUT["judged"]
JG_MATCHED = JUDGE_LAYOUT["matched"]
JG_SETTLED = JUDGE_LAYOUT["settled"]  # matched pairs whose track is older than settle
JG_POSITION_SQUARES = JUDGE_LAYOUT["position_square_sum"]  # [m^2]
JG_VELOCITY_SQUARES = JUDGE_LAYOUT["velocity_square_sum"]  # [m^2/s^2]
JG_ID_SWITCHES = JUDGE_LAYOUT["id_switches"]
JG_MISSED = JUDGE_LAYOUT["missed"]
JG_FALSE = JUDGE_LAYOUT["false_tracks"]
JG_TRACKS = JUDGE_LAYOUT["tracks"]
N_JUDGE = len(JUDGE_LAYOUT)


@dataclass(frozen=True)
class TrackingFigures:
    instants: int  # instants with both lists
    judged: int  # visible moving obstacles over those instants
    matched: int
    position_rmse_m: float | None
    velocity_rmse_mps: float | None
    id_switches: int
    track_seconds: float  # matched, over the instants, times the track period
    id_switches_per_100_track_s: float | None
    missed: int
    false_tracks: int
    missed_pct: float | None
    false_pct: float | None  # of the tracks at the judged instants

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    @staticmethod
    def of(judge: np.ndarray, period: float) -> TrackingFigures:
        """From judge_lists' sums (JUDGE_LAYOUT; of one run or added over runs), lists `period` [s] apart."""
        settled, matched, judged = judge[JG_SETTLED], judge[JG_MATCHED], judge[JG_JUDGED]
        tracks, switches = judge[JG_TRACKS], int(judge[JG_ID_SWITCHES])
        track_seconds = float(matched * period)
        return TrackingFigures(
            int(judge[JG_INSTANTS]), int(judged), int(matched),
            math.sqrt(judge[JG_POSITION_SQUARES] / settled) if settled else None,
            math.sqrt(judge[JG_VELOCITY_SQUARES] / settled) if settled else None,
            switches, track_seconds, 100.0 * switches / track_seconds if track_seconds else None,
            int(judge[JG_MISSED]), int(judge[JG_FALSE]),
            100.0 * judge[JG_MISSED] / judged if judged else None,
            100.0 * judge[JG_FALSE] / tracks if tracks else None,
        )


@kernel
def is_visible(positions, radii, w, rx, ry, range_max):
    """Whether the scanner at (rx, ry) [m] can see obstacle w: in range, and no other disc across the line
    from the robot to its centre."""
    cx = positions[w, 0] - rx
    cy = positions[w, 1] - ry
    dist = math.hypot(cx, cy)
    if dist - radii[w] > range_max:
        return False
    if dist < 1e-9:
        return True
    ux = cx / dist
    uy = cy / dist
    for o in range(radii.shape[0]):
        if o == w:
            continue
        ox = positions[o, 0] - rx
        oy = positions[o, 1] - ry
        along = ox * ux + oy * uy
        if 0.0 < along < dist - radii[w] and abs(ox * uy - oy * ux) < radii[o]:
            return False
    return True


@kernel
def judge_lists(judge, born, last_track, stamp, rows, count, positions, velocities, radii, rx, ry, range_max, gate,
                settle):
    """One instant: the tracker's list rows[:count] (OBSTACLE_ROW; walls' discs skipped) against the world's
    obstacles (positions [m], velocities [m/s], radii [m]; in the same order at every instant), the robot at
    (rx, ry) [m]; adds to judge (JUDGE_LAYOUT). born (rows of id, first stamp; id -1 free) carries the listed
    tracks' ages, last_track (per world obstacle, -1 none) the track it was last matched to."""
    index = np.empty(count, dtype=np.int64)  # the tracks' rows
    n = 0
    for r in range(count):
        if rows[r, OB_ID] < WALL_IDS:
            index[n] = r
            n += 1
    ages = np.empty(n)
    listed = np.empty((n, 2))
    for k in range(n):
        tid = rows[index[k], OB_ID]
        first = stamp
        for q in range(born.shape[0]):
            if born[q, 0] == tid:
                first = born[q, 1]
                break
        ages[k] = stamp - first
        listed[k, 0] = tid
        listed[k, 1] = first
    for q in range(born.shape[0]):  # the listed tracks only: one missing from this list is born again
        born[q, 0] = listed[q, 0] if q < n else -1.0
        born[q, 1] = listed[q, 1] if q < n else 0.0
    m = radii.shape[0]
    cost = np.empty((n, m))
    for k in range(n):
        r = index[k]
        for w in range(m):
            cost[k, w] = math.hypot(rows[r, OB_X] - positions[w, 0], rows[r, OB_Y] - positions[w, 1])
    # the correspondence rule (module docstring): kept pairs first, the rest to the assignment
    kept = np.full(n, -1, dtype=np.int64)
    held = np.zeros(m, dtype=np.bool_)
    for w in range(m):
        for k in range(n):
            if last_track[w] == rows[index[k], OB_ID] and kept[k] < 0 and cost[k, w] <= gate:
                kept[k] = w
                held[w] = True
                break
    free = np.empty((n, m))
    for k in range(n):
        for w in range(m):
            free[k, w] = math.inf if kept[k] >= 0 or held[w] else cost[k, w]
    match = np.empty(n, dtype=np.int64)
    assign(free, gate, match)
    track_of = np.full(m, -1, dtype=np.int64)
    for k in range(n):
        if kept[k] >= 0:
            match[k] = kept[k]
        if match[k] >= 0:
            track_of[match[k]] = k
        else:
            judge[JG_FALSE] += 1.0
    judge[JG_INSTANTS] += 1.0
    judge[JG_TRACKS] += n
    for w in range(m):
        if math.hypot(velocities[w, 0], velocities[w, 1]) < MOVING or not is_visible(positions, radii, w, rx, ry,
                                                                                      range_max):
            continue
        judge[JG_JUDGED] += 1.0
        k = track_of[w]
        if k < 0:
            judge[JG_MISSED] += 1.0
            continue
        judge[JG_MATCHED] += 1.0
        tid = rows[index[k], OB_ID]
        if last_track[w] >= 0.0 and last_track[w] != tid:
            judge[JG_ID_SWITCHES] += 1.0
        last_track[w] = tid
        if ages[k] >= settle:
            judge[JG_SETTLED] += 1.0
            judge[JG_POSITION_SQUARES] += cost[k, w] ** 2
            judge[JG_VELOCITY_SQUARES] += ((rows[index[k], OB_VX] - velocities[w, 0]) ** 2
                                           + (rows[index[k], OB_VY] - velocities[w, 1]) ** 2)


def evaluate(instants: Iterable[tuple[float, np.ndarray, np.ndarray, tuple[float, float]]], range_max: float,
             gate: float = GATE, settle: float = SETTLE, period: float = 0.1) -> TrackingFigures:
    """The figures over (stamp, track rows, world rows, robot x/y at that stamp), in time order."""
    judge = np.zeros(N_JUDGE)
    born = np.empty((0, 2))
    last_track = np.empty(0)
    for stamp, tracks, world, robot in instants:
        tracks = np.ascontiguousarray(tracks, dtype=float).reshape(-1, 6)
        world = np.asarray(world, dtype=float).reshape(-1, 6)
        if len(born) < len(tracks):  # room for every listed track (the batch: the tracker's capacity)
            born = np.vstack([born, np.tile([-1.0, 0.0], (len(tracks) - len(born), 1))])
        if len(last_track) < len(world):
            last_track = np.concatenate([last_track, np.full(len(world) - len(last_track), -1.0)])
        judge_lists(judge, born, last_track, float(stamp), tracks, len(tracks),
                    np.ascontiguousarray(world[:, OB_X:OB_Y + 1]), np.ascontiguousarray(world[:, OB_VX:OB_VY + 1]),
                    np.ascontiguousarray(world[:, OB_RADIUS]), float(robot[0]), float(robot[1]), range_max, gate,
                    settle)
    return TrackingFigures.of(judge, period)
