"""The planner core the node and the headless runs call: one planning step of the chosen method.

`plan_step` is the compiled entry point (the batch engine calls it too): the paper's field
(`apf.apf_step`), the robust one (`robust.robust_step`) or a baseline peer (`dwa.dwa_step`,
`velocity_obstacles.vo_step`), by the settings' method. `ApfPlanner` keeps a
planner's memory between steps and turns the output vector into a `PlannerOutput`.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from twbr_common.jit import kernel
from twbr_common.params import default_of
from twbr_planner.apf import (
    A_METHOD,
    DWA,
    MODES,
    N_MEMORY,
    N_OUTPUTS,
    PAPER,
    PROGRESS_COLUMNS,
    Q_ACTIVE_CONSTRAINT,
    Q_ALPHA,
    Q_DISTANCE,
    Q_ERROR,
    Q_ESCAPE_SIDE,
    Q_F_ATT_X,
    Q_F_ATT_Y,
    Q_F_REP_X,
    Q_F_REP_Y,
    Q_MODE,
    Q_NEAREST_D,
    Q_NEAREST_INDEX,
    Q_OMEGA,
    Q_THREAT,
    Q_V,
    R_HEAD,
    R_LENGTH,
    VO,
    Mode,
    Obstacles,
    apf_step,
    progress_capacity,
    settings_vector,
)
from twbr_planner.dwa import dwa_step
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
from twbr_planner.robust import robust_step
from twbr_planner.velocity_obstacles import vo_step


@kernel
def plan_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
              velocities, radii, distances):
    """One planning step of the settings' method into `out` (Q_*)."""
    if a[A_METHOD] == PAPER:
        apf_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions, radii,
                 distances)
    elif a[A_METHOD] == DWA:
        dwa_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
                 velocities, radii, distances)
    elif a[A_METHOD] == VO:
        vo_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
                velocities, radii, distances)
    else:
        robust_step(a, m, ring, out, stamp, x, y, yaw, speed, target_x, target_y, target_vx, target_vy, positions,
                    velocities, radii, distances)


@dataclass(frozen=True)
class Target:
    x: float
    y: float
    vx: float
    vy: float


@dataclass(frozen=True)
class PlannerOutput:
    stamp: float
    attractive_force: np.ndarray
    repulsive_force: np.ndarray
    total_force: np.ndarray
    desired_heading: float
    heading_error: float
    velocity_cmd: float
    yaw_rate_cmd: float
    distance_to_target: float
    nearest_obstacle_distance: float
    nearest_obstacle_id: int
    mode: Mode
    escape_side: int = 0  # robust: +1 / -1 while following a boundary
    threat_id: int = -1  # robust: the moving obstacle being evaded
    active_constraint_id: int = -1  # robust: the obstacle whose safety constraint changed the command


class ApfPlanner:
    """A planner of either method (eqs. 19-28 plus arrival, following and a stuck report; or the robust
    field): its settings, memory and progress ring between steps."""

    def __init__(self, g: Mapping[str, Any], rate: float | None = None) -> None:
        """`g`: APF_SPECS values; `rate` [Hz]: how often `step` is called (the node's default when None)."""
        self.g = dict(g)
        self.a = settings_vector(self.g)
        self.m = np.zeros(N_MEMORY)
        rate = default_of(PLANNER_NODE_SPECS, "rate") if rate is None else rate
        self._ring = np.zeros((progress_capacity(self.g["stuck_time"], rate), PROGRESS_COLUMNS))
        self._out = np.zeros(N_OUTPUTS)

    def reset(self) -> None:
        self.m[:] = 0.0

    def retune(self, g: Mapping[str, Any]) -> None:
        """New gains and limits from the next plan on; the memory (slew limits, progress) is kept."""
        self.g = dict(g)
        self.a = settings_vector(self.g)

    def warm_up(self) -> None:
        """Load the compiled kernels now, on a copy, so the first planning instant is on time."""
        copy.deepcopy(self).step(0.0, 0.0, 0.0, 0.0, 0.0, Target(5.0, 0.0, 0.0, 0.0),
                                 Obstacles.of([(0, 2.0, 0.0, 0.5)]))

    def stopped(self, stamp: float, mode: Mode) -> PlannerOutput:
        zero = np.zeros(2)
        return PlannerOutput(stamp, zero, zero, zero, math.nan, math.nan, 0.0, 0.0, math.nan, math.inf, -1, mode)

    def _make_room(self) -> None:
        """The node's rate is its own: the ring grows (oldest row first) if a faster rate fills it."""
        if int(self.m[R_LENGTH]) < len(self._ring):
            return
        head = int(self.m[R_HEAD])
        self._ring = np.concatenate([np.roll(self._ring, -head, axis=0), np.zeros_like(self._ring)])
        self.m[R_HEAD] = 0.0

    def step(self, stamp: float, x: float, y: float, yaw: float, speed: float, target: Target | None,
             obstacles: Obstacles) -> PlannerOutput:
        if target is None:
            return self.stopped(stamp, Mode.NO_TARGET)
        self._make_room()
        o = self._out
        d = np.empty(len(obstacles.radii))
        plan_step(self.a, self.m, self._ring, o, float(stamp), float(x), float(y), float(yaw), float(speed),
                  float(target.x), float(target.y), float(target.vx), float(target.vy), obstacles.positions,
                  obstacles.velocities, obstacles.radii, d)
        f_att = o[Q_F_ATT_X:Q_F_ATT_Y + 1].copy()
        f_rep = o[Q_F_REP_X:Q_F_REP_Y + 1].copy()
        return PlannerOutput(
            stamp, f_att, f_rep, f_att + f_rep, float(o[Q_ALPHA]), float(o[Q_ERROR]), float(o[Q_V]),
            float(o[Q_OMEGA]), float(o[Q_DISTANCE]), float(o[Q_NEAREST_D]),
            self._id(obstacles, o[Q_NEAREST_INDEX]), MODES[int(o[Q_MODE])], int(o[Q_ESCAPE_SIDE]),
            self._id(obstacles, o[Q_THREAT]), self._id(obstacles, o[Q_ACTIVE_CONSTRAINT]),
        )

    @staticmethod
    def _id(obstacles: Obstacles, index: float) -> int:
        return int(obstacles.ids[int(index)]) if index >= 0 else -1
