"""A run's figures of merit, computed from its recording alone (decoded messages -> arrays -> metrics).

Time is the messages' header stamps (sim time), never the receive time. The pitch is the true one from
odom's orientation; the references, measurements and commands are what the controller published.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from twbr_batch.response import PITCH_BAND, StepResponse, settle_time, step_response
from twbr_common.geometry import rpy_from_quaternion
from twbr_common.guard import POSITION_LIMIT, InputGuard, Verdict

TRANSIENT_S = 2.0  # s after the first non-zero reference: the paper's "first transient" (1.5-1.75 s)
CONTROLLER_FIELDS = (
    "velocity_ref", "velocity", "yaw_rate_ref", "yaw_rate", "pitch_ref", "pitch", "pitch_rate",
    "common_torque", "differential_torque", "left_torque", "right_torque", "dt",
    "pitch_ref_limited", "torque_saturated", "cmd_vel_stale", "fallen", "enabled", "pitch_estimated",
)


# What metrics and figures read (decoding only these keeps the analysis of a long run to seconds).
MEASURED_TOPICS = ("/clock", "/controller_state", "/odom", "/joint_states", "/sim_status", "/world_status", "/target",
                   "/obstacles", "/planner_state")


def stamp_of(msg: Any) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


@dataclass
class RunSeries:
    """Arrays of one run, by topic, each with its own stamp axis."""

    control_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    control: dict[str, np.ndarray] = field(default_factory=dict)
    odom_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    x_c: np.ndarray = field(default_factory=lambda: np.empty(0))
    y_c: np.ndarray = field(default_factory=lambda: np.empty(0))
    pitch: np.ndarray = field(default_factory=lambda: np.empty(0))  # true pitch from odom [rad]
    # The true speed and yaw rate at control_t: the simulator's ground_truth where it published one
    # (realistic sensors), else what the controller measured (ideal sensors: the same thing).
    velocity_true: np.ndarray = field(default_factory=lambda: np.empty(0))
    yaw_rate_true: np.ndarray = field(default_factory=lambda: np.empty(0))
    joints_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    wheel_effort: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))  # delivered [N·m]
    sim_status: list[Any] = field(default_factory=list)
    world_status: list[Any] = field(default_factory=list)
    target_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    target_xy: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    # (stamp, [(id, x, y, radius), ...]) per obstacles message
    obstacles: list[tuple[float, list[tuple[int, float, float, float]]]] = field(default_factory=list)
    planner: list[Any] = field(default_factory=list)  # PlannerState messages in stamp order
    counts: dict[str, int] = field(default_factory=dict)
    refused: dict[str, int] = field(default_factory=dict)  # messages no node would accept, by topic
    messages: dict[str, list[tuple[int, Any]]] = field(default_factory=dict)


# The numbers each measured topic contributes, for admission (see _admitted).
_VALUES: dict[str, Any] = {
    "/odom": lambda m: (m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.orientation.x,
                        m.pose.pose.orientation.y, m.pose.pose.orientation.z, m.pose.pose.orientation.w,
                        m.twist.twist.linear.x, m.twist.twist.angular.z),
    "/target": lambda m: (m.pose.pose.position.x, m.pose.pose.position.y, m.twist.twist.linear.x),
    "/obstacles": lambda m: tuple(v for o in m.obstacles for v in (o.position.x, o.position.y, o.radius)),
    "/planner_state": lambda m: (m.velocity_cmd, m.yaw_rate_cmd, m.distance_to_target),
    "/controller_state": lambda m: tuple(float(getattr(m, name)) for name in CONTROLLER_FIELDS),
    "/joint_states": lambda m: tuple(m.effort),
    "/world_status": lambda m: (m.target_distance,),
    "/sim_status": lambda m: (m.pitch,),
}


# A recorded message stamped further than this ahead of the bag's clock came from another clock. Wider than
# the nodes' tolerance: the recorder may take a state before the /clock that announces it, and it is niced.
BAG_FUTURE_TOLERANCE = 0.5  # [s]


class BagClock:
    """What the graph's clock read when the recorder received a message: the newest /clock received by
    then (sim time), or the receive time itself when the bag has no /clock (a graph on wall time)."""

    def __init__(self, clock_messages: list[tuple[int, Any]]) -> None:
        received = sorted((t, m.clock.sec + m.clock.nanosec * 1e-9) for t, m in clock_messages)
        self._received = np.array([t for t, _ in received], dtype=np.int64)
        # A restarted simulator sends its clock back: the clock at a receipt is the last one sent, not the max.
        self._clock = np.array([c for _, c in received])

    def at(self, received_ns: int) -> float:
        if not len(self._received):
            return received_ns * 1e-9
        i = int(np.searchsorted(self._received, received_ns, side="right")) - 1
        return float(self._clock[i]) if i >= 0 else 0.0


def _admitted(topic: str, items: list[tuple[int, Any]], refused: dict[str, int], clock: BagClock,
              keep_last: bool = False) -> list[Any]:
    """The messages a node would have accepted, in stamp order, one per stamp.

    A bag records everything on a topic, including what another publisher injected (NaN, absurd values, no
    stamp, out of order, stamped ahead of the clock); the metrics are of the run, so they read only what
    passes the nodes' own guard. Values and order are judged, and stamps against the bag's clock (an
    unstamped message comes out of order). A lockstep simulator may re-offer its first state: equal stamps
    keep the first (statuses: the last, which carries the final counters).
    """
    values = _VALUES.get(topic, lambda m: ())
    # The widest of the nodes' limits; no timeout (the recorder is allowed to lag).
    guard = InputGuard(math.inf, require_stamp=True, limit=POSITION_LIMIT, future_tolerance=BAG_FUTURE_TOLERANCE)
    by_stamp: dict[float, Any] = {}
    for received, msg in sorted(items, key=lambda item: item[0]):
        t = stamp_of(msg)
        if guard.offer(t, values(msg), now=clock.at(received)) is not Verdict.ACCEPTED:
            continue
        if keep_last:
            by_stamp[t] = msg
        else:
            by_stamp.setdefault(t, msg)
    if guard.rejected_total:
        refused[topic] = guard.rejected_total
    return [by_stamp[t] for t in sorted(by_stamp)]


def series_from_messages(messages: Mapping[str, list[tuple[int, Any]]]) -> RunSeries:
    s = RunSeries(counts={t: len(v) for t, v in messages.items()}, messages=dict(messages))
    clock = BagClock(messages.get("/clock", []))
    control = _admitted("/controller_state", messages.get("/controller_state", []), s.refused, clock)
    s.control_t = np.array([stamp_of(m) for m in control])
    s.control = {name: np.array([float(getattr(m, name)) for m in control]) for name in CONTROLLER_FIELDS}
    # With realistic sensors odom is dead reckoning from encoder counts: the simulator's ground_truth is
    # what the robot really did.
    truth = _admitted("/ground_truth", messages.get("/ground_truth", []), s.refused, clock)
    odom = truth or _admitted("/odom", messages.get("/odom", []), s.refused, clock)
    s.odom_t = np.array([stamp_of(m) for m in odom])
    s.x_c = np.array([m.pose.pose.position.x for m in odom])
    s.y_c = np.array([m.pose.pose.position.y for m in odom])
    s.pitch = np.array([rpy_from_quaternion(m.pose.pose.orientation.x, m.pose.pose.orientation.y,
                                            m.pose.pose.orientation.z, m.pose.pose.orientation.w)[1] for m in odom])
    if truth:
        s.velocity_true = np.interp(s.control_t, s.odom_t, [m.twist.twist.linear.x for m in truth])
        s.yaw_rate_true = np.interp(s.control_t, s.odom_t, [m.twist.twist.angular.z for m in truth])
    else:
        s.velocity_true, s.yaw_rate_true = s.control["velocity"], s.control["yaw_rate"]
    joints = _admitted("/joint_states", messages.get("/joint_states", []), s.refused, clock)
    s.joints_t = np.array([stamp_of(m) for m in joints])
    s.wheel_effort = np.array([list(m.effort)[:2] for m in joints]).reshape(-1, 2)
    s.sim_status = _admitted("/sim_status", messages.get("/sim_status", []), s.refused, clock, keep_last=True)
    s.world_status = _admitted("/world_status", messages.get("/world_status", []), s.refused, clock, keep_last=True)
    target = _admitted("/target", messages.get("/target", []), s.refused, clock)
    s.target_t = np.array([stamp_of(m) for m in target])
    s.target_xy = np.array([(m.pose.pose.position.x, m.pose.pose.position.y) for m in target]).reshape(-1, 2)
    s.obstacles = [(stamp_of(m), [(o.id, o.position.x, o.position.y, o.radius) for o in m.obstacles])
                   for m in _admitted("/obstacles", messages.get("/obstacles", []), s.refused, clock)]
    s.planner = _admitted("/planner_state", messages.get("/planner_state", []), s.refused, clock)
    return s


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2))) if len(x) else math.nan


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


@dataclass
class NavigationMetrics:
    """Outcome of a run with a world (docs/metrics.md); the last four only with a planner."""

    reached: bool
    time_to_reach_s: float | None
    collisions: int | None
    min_clearance_m: float | None  # sampled at the world rate
    final_target_distance_m: float | None
    pitch_by_mode: dict[str, dict[str, float]] | None = None  # mode -> pitch bounds [rad] and time in it [s]
    stuck_time_s: float | None = None
    planning_time_median_ms: float | None = None  # the planner node's wall time per plan (planner_state)
    planning_time_p99_ms: float | None = None


PLANNER_ONLY = ("pitch_by_mode", "stuck_time_s", "planning_time_median_ms", "planning_time_p99_ms")


@dataclass
class BagSummary:
    path: str
    storage: str
    message_count: int


@dataclass
class RunMetrics:
    """A run's figures of merit: what metrics.json holds (docs/metrics.md), flat, by `as_json`."""

    scenario: str
    seed: int
    sim_time_s: float
    wall_time_s: float  # the simulator's stepping
    real_time_factor: float | None
    fallen: bool
    pitch_min_rad: float
    pitch_max_rad: float
    pitch_final_rad: float
    pitch_band_rad: float
    pitch_settle_time_s: float | None
    pitch_after_settle_min_rad: float | None
    pitch_after_settle_max_rad: float | None
    v_rmse: float
    w_rmse: float
    max_torque_nm: float
    max_delivered_torque_nm: float
    torque_saturated_samples: int
    cmd_vel_stale_samples: int
    lockstep_timeouts: int | None
    commands_rejected: int | None
    # Traction, from the simulator's last sim_status (None from a driver that does not report it)
    wheel_lift_events: int | None
    wheel_slip_events: int | None
    wheel_lifted_time_s: float | None
    wheel_slipping_time_s: float | None
    # The estimator's pitch against the truth (ground_truth), when the controller estimated [rad]
    pitch_estimate_rms_error_rad: float | None
    control_samples: int
    messages: dict[str, int]
    messages_refused: dict[str, int]
    transient_s: float
    pitch_after_transient_min_rad: float | None
    pitch_after_transient_max_rad: float | None
    # The first step of each reference, for scripted scenarios (a name -> None: no step in the run).
    steps: dict[str, StepResponse | None] = field(default_factory=dict)
    navigation: NavigationMetrics | None = None
    # What the runner adds: why the run ended, its whole wall time, the bag.
    ended_by: str | None = None
    run_wall_time_s: float | None = None
    bag: BagSummary | None = None
    # Publishers on the run's topics that were none of the run's own nodes (another graph, an injector):
    # the run then measured more than its own graph, and the runner exits 1.
    foreign_publishers: list[str] | None = None

    def as_json(self) -> dict[str, Any]:
        out = {f.name: getattr(self, f.name) for f in fields(self)
               if f.name not in ("steps", "navigation", "ended_by", "run_wall_time_s", "bag", "foreign_publishers")}
        out.update({name: r.as_dict() if r is not None else None for name, r in self.steps.items()})
        if self.navigation is not None:
            out.update({k: v for k, v in asdict(self.navigation).items()
                        if v is not None or k not in PLANNER_ONLY})
        for name in ("ended_by", "run_wall_time_s", "bag", "foreign_publishers"):
            value = getattr(self, name)
            if value is not None:
                out[name] = asdict(value) if name == "bag" else value
        return out


def navigation_metrics(s: RunSeries) -> NavigationMetrics:
    """Outcome of a run with a world: reached, when, collisions, clearance, pitch per planner mode."""
    status = s.world_status
    reached = [m for m in status if m.target_reached]
    clearances = [m.clearance for m in status if math.isfinite(m.clearance)]
    out = NavigationMetrics(
        reached=bool(reached),
        time_to_reach_s=stamp_of(reached[0]) if reached else None,
        collisions=int(status[-1].collision_count) if status else None,
        min_clearance_m=min(clearances) if clearances else None,
        final_target_distance_m=float(status[-1].target_distance) if status else None,
    )
    if s.planner:
        t = np.array([stamp_of(m) for m in s.planner])
        modes = np.array([m.mode for m in s.planner])
        # The mode in force at each odom sample: the last planner decision at or before it.
        idx = np.searchsorted(t, s.odom_t, side="right") - 1
        per_mode = {}
        for mode in sorted(set(modes)):
            mask = (idx >= 0) & (modes[np.maximum(idx, 0)] == mode)
            if mask.any():
                per_mode[mode] = {"pitch_min_rad": float(s.pitch[mask].min()),
                                  "pitch_max_rad": float(s.pitch[mask].max()),
                                  "time_s": float(mask.sum() * np.median(np.diff(s.odom_t)))}
        out.pitch_by_mode = per_mode
        out.stuck_time_s = per_mode.get("stuck", {}).get("time_s", 0.0)
        planning = np.array([m.planning_time for m in s.planner if m.planning_time > 0.0])
        if len(planning):
            out.planning_time_median_ms = float(1e3 * np.median(planning))
            out.planning_time_p99_ms = float(1e3 * np.percentile(planning, 99))
    return out


def _pitch_estimate_error(s: RunSeries) -> float | None:
    """RMS of the controller's pitch (estimated) against the true pitch at the same stamps."""
    estimated = s.control["pitch_estimated"].astype(bool) if "pitch_estimated" in s.control else None
    if estimated is None or not estimated.any() or not len(s.odom_t):
        return None
    truth = np.interp(s.control_t[estimated], s.odom_t, s.pitch)
    return _rms(s.control["pitch"][estimated] - truth)


def compute_metrics(s: RunSeries, scenario: str, seed: int, wall_time_s: float,
                    step_responses: bool = True) -> RunMetrics:
    if len(s.control_t) == 0 or len(s.odom_t) == 0:
        raise ValueError("the recording has no controller_state or no odom: nothing to measure")
    c = s.control
    sim_time = float(max(s.odom_t[-1], s.control_t[-1]))
    final_pitch = float(np.median(s.pitch[s.odom_t >= sim_time - max(0.5, 0.2 * sim_time)]))
    pitch_settle = settle_time(s.odom_t, s.pitch, final_pitch, PITCH_BAND, 0.0)
    settled = s.odom_t >= (pitch_settle if math.isfinite(pitch_settle) else math.inf)
    last_status = s.sim_status[-1] if s.sim_status else None
    fallen = bool(c["fallen"].any()) or any(m.fallen for m in s.sim_status)
    commanded = max(float(np.abs(c["left_torque"]).max()), float(np.abs(c["right_torque"]).max()))
    delivered = float(np.abs(s.wheel_effort).max()) if len(s.wheel_effort) else math.nan
    # After the first transient: from TRANSIENT_S after the first non-zero reference to the end.
    moving = np.flatnonzero((np.abs(c["velocity_ref"]) > 1e-9) | (np.abs(c["yaw_rate_ref"]) > 1e-9))
    start = (s.control_t[moving[0]] if len(moving) else 0.0) + TRANSIENT_S
    late = s.odom_t >= start
    steps = {}
    if step_responses:
        for name, signal, ref in (("velocity_step", s.velocity_true, "velocity_ref"),
                                  ("yaw_rate_step", s.yaw_rate_true, "yaw_rate_ref")):
            steps[name] = step_response(s.control_t, signal, c[ref])
    return RunMetrics(
        scenario=scenario,
        seed=seed,
        sim_time_s=sim_time,
        wall_time_s=wall_time_s,
        real_time_factor=sim_time / wall_time_s if wall_time_s > 0 else None,
        fallen=fallen,
        pitch_min_rad=float(s.pitch.min()),
        pitch_max_rad=float(s.pitch.max()),
        pitch_final_rad=final_pitch,
        pitch_band_rad=PITCH_BAND,
        pitch_settle_time_s=_finite(pitch_settle),
        pitch_after_settle_min_rad=float(s.pitch[settled].min()) if settled.any() else None,
        pitch_after_settle_max_rad=float(s.pitch[settled].max()) if settled.any() else None,
        v_rmse=_rms(c["velocity"] - c["velocity_ref"]),
        w_rmse=_rms(c["yaw_rate"] - c["yaw_rate_ref"]),
        max_torque_nm=commanded,
        max_delivered_torque_nm=delivered,
        torque_saturated_samples=int(c["torque_saturated"].sum()),
        cmd_vel_stale_samples=int(c["cmd_vel_stale"].sum()),
        lockstep_timeouts=int(last_status.lockstep_timeouts) if last_status else None,
        commands_rejected=int(last_status.commands_rejected) if last_status else None,
        wheel_lift_events=int(last_status.lift_events) if last_status else None,
        wheel_slip_events=int(last_status.slip_events) if last_status else None,
        wheel_lifted_time_s=float(last_status.lifted_time) if last_status else None,
        wheel_slipping_time_s=float(last_status.slipping_time) if last_status else None,
        pitch_estimate_rms_error_rad=_pitch_estimate_error(s),
        control_samples=len(s.control_t),
        messages=s.counts,
        messages_refused=s.refused,
        transient_s=TRANSIENT_S,
        pitch_after_transient_min_rad=float(s.pitch[late].min()) if late.any() else None,
        pitch_after_transient_max_rad=float(s.pitch[late].max()) if late.any() else None,
        steps=steps,
        navigation=navigation_metrics(s) if s.world_status else None,
    )
