"""How well the tracks follow the world: issue 36's tracker figures, from a run's obstacle lists.

At every instant that has both a track list (tracker_node's `obstacles`) and the world's own list (the
simulator's, remapped to `obstacles_truth` by the runner), the tracks are matched one to one to the world's
obstacles by the Hungarian method on the distance between centres, within `gate` (the tracker's own
assignment kernel). Walls' discs (ids from WALL_IDS) are the wall's, not tracks, and are left out.
Judged on the world's moving obstacles that are *visible*: within `range_max` of the robot and with no
other obstacle's disc across the line from the robot to their centre (CLEAR-MOT's rules, Bernardin &
Stiefelhagen 2008, on our discs):

- position and velocity RMSE of the matched pairs whose track is older than `settle` (a track's first
  second is its filter's start);
- ID switches: a visible obstacle matched to another track than the one it was last matched to;
- missed: a visible moving obstacle without a track; false: a track matched to no obstacle at all;
- per 100 track-seconds: ID switches over the time the matched tracks existed.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from twbr_tracker.assignment import assign
from twbr_tracker.tracker import WALL_IDS

# Rows of an obstacle list: id, x, y, vx, vy, radius (twbr_common.cdr.obstacle_rows)
OB_ID, OB_X, OB_Y, OB_VX, OB_VY, OB_RADIUS = range(6)
MOVING = 0.05  # [m/s] an obstacle slower than this is standing (a person waiting is not judged on velocity)


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


def visible(robot: tuple[float, float], rows: np.ndarray, range_max: float) -> np.ndarray:
    """Which of the world's obstacles the scanner at `robot` can see: in range, and no other disc across
    the line from the robot to their centre."""
    rx, ry = robot
    centres = rows[:, OB_X:OB_Y + 1] - (rx, ry)
    dist = np.hypot(centres[:, 0], centres[:, 1])
    seen = dist - rows[:, OB_RADIUS] <= range_max
    for i in np.flatnonzero(seen):
        if dist[i] < 1e-9:
            continue
        u = centres[i] / dist[i]
        along = centres @ u
        across = np.abs(centres[:, 0] * u[1] - centres[:, 1] * u[0])
        blocking = (along > 0.0) & (along < dist[i] - rows[i, OB_RADIUS]) & (across < rows[:, OB_RADIUS])
        blocking[i] = False
        seen[i] = not blocking.any()
    return seen


def evaluate(instants: Iterable[tuple[float, np.ndarray, np.ndarray, tuple[float, float]]], range_max: float,
             gate: float = 0.5, settle: float = 1.0, period: float = 0.1) -> TrackingFigures:
    """The figures over (stamp, track rows, world rows, robot x/y at that stamp), in time order."""
    born: dict[int, float] = {}  # track id -> first stamp seen
    last_track: dict[int, int] = {}  # world id -> the track it was last matched to
    pos_sq, vel_sq = [], []
    n_instants = judged = matched = switches = missed = false = tracks_total = 0
    for stamp, tracks, world, robot in instants:
        tracks = tracks[tracks[:, OB_ID] < WALL_IDS]
        for tid in tracks[:, OB_ID].astype(int):
            born.setdefault(int(tid), stamp)
        n_instants += 1
        tracks_total += len(tracks)
        cost = np.hypot(tracks[:, None, OB_X] - world[None, :, OB_X], tracks[:, None, OB_Y] - world[None, :, OB_Y])
        match = np.full(len(tracks), -1, dtype=np.int64)
        assign(np.ascontiguousarray(cost.reshape(len(tracks), len(world))), gate, match)
        false += int((match < 0).sum())
        track_of = {int(w): i for i, w in enumerate(match) if w >= 0}
        moving = np.hypot(world[:, OB_VX], world[:, OB_VY]) >= MOVING
        judged_here = np.flatnonzero(moving & visible(robot, world, range_max))
        for w in judged_here:
            judged += 1
            i = track_of.get(int(w))
            if i is None:
                missed += 1
                continue
            matched += 1
            wid, tid = int(world[w, OB_ID]), int(tracks[i, OB_ID])
            if last_track.get(wid, tid) != tid:
                switches += 1
            last_track[wid] = tid
            if stamp - born[tid] >= settle:
                pos_sq.append(cost[i, w] ** 2)
                vel_sq.append((tracks[i, OB_VX] - world[w, OB_VX]) ** 2 + (tracks[i, OB_VY] - world[w, OB_VY]) ** 2)
    track_seconds = matched * period
    return TrackingFigures(
        n_instants, judged, matched,
        math.sqrt(float(np.mean(pos_sq))) if pos_sq else None,
        math.sqrt(float(np.mean(vel_sq))) if vel_sq else None,
        switches, track_seconds, 100.0 * switches / track_seconds if track_seconds else None,
        missed, false, 100.0 * missed / judged if judged else None,
        100.0 * false / tracks_total if tracks_total else None,
    )
