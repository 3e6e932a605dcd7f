"""A run's figures of merit, computed from its recording alone (messages, streamed -> arrays -> metrics).

Time is the messages' header stamps (sim time), never the receive time. The pitch is the true one from
odom's orientation; the references, measurements and commands are what the controller published.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from twbr_batch.response import PITCH_BAND, StepResponse, settle_time, step_response
from twbr_common.cdr import UNKNOWN_POSITION, obstacle_rows, obstacle_rows_of
from twbr_common.geometry import rpy_from_quaternion
from twbr_common.guard import POSITION_LIMIT, InputGuard, Verdict
from twbr_runner.bag_reader import iter_messages

TRANSIENT_S = 2.0  # s after the first non-zero reference: the paper's "first transient" (1.5-1.75 s)
CONTROLLER_FIELDS = (
    "velocity_ref", "velocity", "yaw_rate_ref", "yaw_rate", "pitch_ref", "pitch", "pitch_rate",
    "common_torque", "differential_torque", "left_torque", "right_torque", "dt",
    "pitch_ref_limited", "torque_saturated", "cmd_vel_stale", "fallen", "enabled", "pitch_estimated",
    "collision_limited",
)


# What metrics and figures read (decoding only these keeps the analysis of a long run to seconds).
MEASURED_TOPICS = ("/clock", "/controller_state", "/odom", "/ground_truth", "/joint_states", "/sim_status",
                   "/world_status", "/target", "/target_tracked", "/target_detections", "/obstacles", "/obstacles_truth",
                   "/planner_state")
OBSTACLE_TOPICS = ("/obstacles", "/obstacles_truth")  # read from their bytes; the truth's with the LiDAR


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
    # With the LiDAR: the tracker's fused target (from target_detections), for its error against `target`
    # (the instants its position was known: a prior, or after a sighting), and the first look that saw it [s]
    tracked_target_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    tracked_target_xy: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    target_first_seen: float = math.nan
    # (stamp, rows of id, x, y, vx, vy, radius): snapshots of the world's obstacle list
    # (OBSTACLE_SNAPSHOT_PERIOD): `obstacles_truth` where the run had one (the LiDAR's), else `obstacles`
    obstacles: list[tuple[float, np.ndarray]] = field(default_factory=list)
    # With the LiDAR: every list of both, by stamp, for the tracker's figures (twbr_tracker.evaluation)
    tracked: dict[float, np.ndarray] = field(default_factory=dict)
    truth_obstacles: dict[float, np.ndarray] = field(default_factory=dict)
    planner: list[Any] = field(default_factory=list)  # PlannerState messages in stamp order
    counts: dict[str, int] = field(default_factory=dict)
    refused: dict[str, int] = field(default_factory=dict)  # messages no node would accept, by topic


# The numbers each measured topic contributes, for admission (see _admitted).
_VALUES: dict[str, Any] = {
    "/odom": lambda m: (m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.orientation.x,
                        m.pose.pose.orientation.y, m.pose.pose.orientation.z, m.pose.pose.orientation.w,
                        m.twist.twist.linear.x, m.twist.twist.angular.z),
    "/target": lambda m: (m.pose.pose.position.x, m.pose.pose.position.y, m.twist.twist.linear.x),
    "/target_tracked": lambda m: (m.pose.pose.position.x, m.pose.pose.position.y, m.twist.twist.linear.x),
    "/target_detections": lambda m: tuple(v for q in m.poses for v in (q.position.x, q.position.y)),
    "/planner_state": lambda m: (m.velocity_cmd, m.yaw_rate_cmd, m.distance_to_target),
    # (a field a bag recorded before it existed reads as 0)
    "/controller_state": lambda m: tuple(float(getattr(m, name, 0.0)) for name in CONTROLLER_FIELDS),
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

    def __len__(self) -> int:
        return len(self._received)

    def at(self, received_ns: int) -> float:
        if not len(self._received):
            return received_ns * 1e-9
        i = int(np.searchsorted(self._received, received_ns, side="right")) - 1
        return float(self._clock[i]) if i >= 0 else 0.0


class _Admission:
    """One topic's messages as a node would have accepted them, streamed: the nodes' guard in receive order,
    judged against the bag's clock, one message per stamp.

    A bag records everything on a topic, including what another publisher injected (NaN, absurd values, no
    stamp, out of order, stamped ahead of the clock); the metrics are of the run, so they read only what
    passes the nodes' own guard. The guard refuses a stamp older than the last accepted one, so what passes
    comes in stamp order; a lockstep simulator may re-offer its first state: equal stamps keep the first
    (statuses: the last, which carries the final counters).
    """

    def __init__(self, keep_last: bool = False) -> None:
        # The widest of the nodes' limits; no timeout (the recorder is allowed to lag).
        self.guard = InputGuard(math.inf, require_stamp=True, limit=POSITION_LIMIT,
                                future_tolerance=BAG_FUTURE_TOLERANCE)
        self.keep_last = keep_last
        self.last: float | None = None

    def offer(self, t: float, values, now: float) -> str:
        """'new' (append), 'replace' (the last one, same stamp) or 'drop'."""
        if self.guard.offer(t, values, now) is not Verdict.ACCEPTED:
            return "drop"
        if t == self.last:
            return "replace" if self.keep_last else "drop"
        self.last = t
        return "new"


def _put(rows: list, verdict: str, row: Any) -> None:
    if verdict == "new":
        rows.append(row)
    elif verdict == "replace":
        rows[-1] = row


# Obstacle lists kept for the figures: one every this many seconds of sim time, and the last. A recording
# of 5,000 obstacles 50 times a second would otherwise be held whole (GBs); the metrics read none of them.
OBSTACLE_SNAPSHOT_PERIOD = 0.25  # [s]
# Lists kept whole for the tracker's figures: those of a LiDAR run up to this many rows (a world of people
# and a wall's chain; a flood's 5,000-row arrays are not a tracker's and are left out).
TRACKED_ROWS_MAX = 500
_STATUS_TOPICS = ("/sim_status", "/world_status")
# The simulator's streams, one message per state: together they show how far its clock has gone
CLOCK_STREAMS = ("/odom", "/joint_states", "/controller_state")


class SeriesBuilder:
    """A run's series from its messages one at a time, in receive order: each message is reduced to the
    numbers the metrics and figures read as it comes, and never kept (obstacle lists: snapshots). Memory
    grows with the run's sim time (~1 KB per sim second per topic at 200 Hz), not with the bag's size."""

    def __init__(self, clock: BagClock) -> None:
        self.clock = clock
        self.counts: dict[str, int] = {}
        self._admission: dict[str, _Admission] = {}
        self._streams_clock = -math.inf  # the newest stamp accepted on CLOCK_STREAMS [s] (see _offer)
        self._rows: dict[str, list] = {}
        self._snapshots: dict[str, tuple[list, list]] = {t: ([], []) for t in OBSTACLE_TOPICS}  # kept, last
        self._whole: dict[str, dict[float, np.ndarray]] = {t: {} for t in OBSTACLE_TOPICS}

    def _offer(self, topic: str, t: float, values, received: int) -> str:
        admission = self._admission.get(topic)
        if admission is None:
            admission = self._admission[topic] = _Admission(keep_last=topic in _STATUS_TOPICS)
        # Judged against the newest of /clock and the stamps accepted on the simulator's streams: the run's
        # clock had reached them. The recorder of a loaded host misses samples of every topic, and a reliable
        # subscription holds the samples after a missed one until it is resent: measured with two graphs on
        # 2 cores, /clock came 1.2 s of wall time (3.3 s of sim time) late, joint_states 0.27 s,
        # controller_state 0.47 s, odom 0.04 s. Read against /clock alone, every odom of that gap was ahead
        # of the clock and left out. A stamp from further ahead is still refused: it must be within the
        # tolerance of what was accepted before it.
        verdict = admission.offer(t, values, max(self.clock.at(received), self._streams_clock))
        if verdict == "new" and topic in CLOCK_STREAMS:
            self._streams_clock = max(self._streams_clock, t)
        return verdict

    def add(self, topic: str, received: int, msg: Any) -> None:
        """One message received at `received` [ns]: decoded, or for the obstacle lists their CDR bytes too."""
        self.counts[topic] = self.counts.get(topic, 0) + 1
        if topic in OBSTACLE_TOPICS:
            self._add_obstacles(topic, received, msg)
            return
        if topic not in _VALUES and topic not in ("/ground_truth",):
            return
        t = stamp_of(msg)
        values = _VALUES.get(topic if topic != "/ground_truth" else "/odom")(msg)
        verdict = self._offer(topic, t, values, received)
        if verdict == "drop":
            return
        if topic in ("/odom", "/ground_truth"):
            q = msg.pose.pose.orientation
            row = (t, msg.pose.pose.position.x, msg.pose.pose.position.y, rpy_from_quaternion(q.x, q.y, q.z, q.w)[1],
                   msg.twist.twist.linear.x, msg.twist.twist.angular.z)
        elif topic == "/controller_state":
            row = (t, *values)
        elif topic == "/joint_states":
            row = (t, *(list(msg.effort)[:2]))
        elif topic in ("/target", "/target_tracked"):
            row = (t, msg.pose.pose.position.x, msg.pose.pose.position.y, msg.pose.covariance[0])
        elif topic == "/target_detections":
            row = (t, len(msg.poses))
        else:  # statuses and planner_state: a few fields each, 20 Hz
            row = msg
        _put(self._rows.setdefault(topic, []), verdict, row)

    def _add_obstacles(self, topic: str, received: int, msg: Any) -> None:
        read = obstacle_rows(msg) if isinstance(msg, (bytes, bytearray, memoryview)) else obstacle_rows_of(msg)
        if read is None:
            return
        t = read.stamp.sec + read.stamp.nanosec * 1e-9
        if self._offer(topic, t, read.rows[:, (1, 2, 5)], received) != "new":
            return
        snapshot = (t, read.rows.copy())
        if len(read.rows) <= TRACKED_ROWS_MAX:
            self._whole[topic][t] = snapshot[1]
        kept, last = self._snapshots[topic]
        if t >= (kept[-1][0] if kept else -math.inf) + OBSTACLE_SNAPSHOT_PERIOD - 1e-9:
            kept.append(snapshot)
            last.clear()
        else:
            last[:] = [snapshot]

    def series(self) -> RunSeries:
        s = RunSeries(counts=dict(self.counts))
        s.refused = {topic: a.guard.rejected_total for topic, a in self._admission.items() if a.guard.rejected_total}
        control = self._rows.get("/controller_state", [])
        s.control_t = np.array([r[0] for r in control])
        s.control = {name: np.array([r[1 + i] for r in control]) for i, name in enumerate(CONTROLLER_FIELDS)}
        # With realistic sensors odom is dead reckoning from encoder counts: the simulator's ground_truth is
        # what the robot really did.
        truth = self._rows.get("/ground_truth", [])
        odom = np.array(truth or self._rows.get("/odom", []), dtype=float).reshape(-1, 6)
        s.odom_t, s.x_c, s.y_c, s.pitch = odom[:, 0], odom[:, 1], odom[:, 2], odom[:, 3]
        if truth:
            s.velocity_true = np.interp(s.control_t, s.odom_t, odom[:, 4])
            s.yaw_rate_true = np.interp(s.control_t, s.odom_t, odom[:, 5])
        else:
            s.velocity_true, s.yaw_rate_true = s.control["velocity"], s.control["yaw_rate"]
        joints = self._rows.get("/joint_states", [])
        s.joints_t = np.array([r[0] for r in joints])
        s.wheel_effort = np.array([r[1:3] for r in joints], dtype=float).reshape(-1, 2)
        s.sim_status = self._rows.get("/sim_status", [])
        s.world_status = self._rows.get("/world_status", [])
        target = np.array(self._rows.get("/target", []), dtype=float).reshape(-1, 4)
        s.target_t, s.target_xy = target[:, 0], target[:, 1:3]
        tracked = np.array(self._rows.get("/target_tracked", []), dtype=float).reshape(-1, 4)
        tracked = tracked[tracked[:, 3] != UNKNOWN_POSITION]
        s.tracked_target_t, s.tracked_target_xy = tracked[:, 0], tracked[:, 1:3]
        s.target_first_seen = min((t for t, seen in self._rows.get("/target_detections", []) if seen), default=math.nan)
        shown = "/obstacles_truth" if self.counts.get("/obstacles_truth") else "/obstacles"
        s.obstacles = [*self._snapshots[shown][0], *self._snapshots[shown][1]]
        if shown == "/obstacles_truth":
            s.tracked, s.truth_obstacles = self._whole["/obstacles"], self._whole["/obstacles_truth"]
        s.planner = self._rows.get("/planner_state", [])
        return s


def series_from_messages(messages: Mapping[str, list[tuple[int, Any]]]) -> RunSeries:
    """The series of decoded messages by topic ({topic: [(receive time ns, message), ...]})."""
    builder = SeriesBuilder(BagClock(messages.get("/clock", [])))
    received_order = sorted(((received, topic, k) for topic, items in messages.items()
                             for k, (received, _msg) in enumerate(items)), key=lambda item: item[0])
    for received, topic, k in received_order:  # as a bag is read: every topic, in receive order
        builder.add(topic, received, messages[topic][k][1])
    return builder.series()


def series_from_bag(bag_dir: Path, undecodable: Counter | None = None) -> RunSeries:
    """The series of a recorded run, streamed from its bag: /clock first (the bag's clock), then every
    measured topic message by message, obstacle arrays read from their bytes."""
    clock = BagClock([(received, msg) for _, received, msg in iter_messages(bag_dir, ["/clock"], undecodable)])
    builder = SeriesBuilder(clock)
    for topic, received, msg in iter_messages(bag_dir, [t for t in MEASURED_TOPICS if t != "/clock"], undecodable,
                                              raw=OBSTACLE_TOPICS):
        builder.add(topic, received, msg)
    builder.counts["/clock"] = len(clock)
    return builder.series()


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


RUNNER_ADDED = ("steps", "navigation", "ended_by", "run_wall_time_s", "bag", "foreign_publishers", "perception",
                "tracking")


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
    torque_step_max_nm: float  # a wheel's largest commanded-torque change between two samples (issue 35)
    torque_saturated_samples: int
    cmd_vel_stale_samples: int
    collision_limited_samples: int  # commands the collision monitor lowered (twbr_control.collision_monitor)
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
    # What the planner's obstacles came from ("lidar": tracker_node on the scan; "truth": the world's), and
    # with the LiDAR the tracker's figures (tracking_metrics, and its scan -> obstacles latency).
    perception: str | None = None
    tracking: dict[str, Any] | None = None

    def as_json(self) -> dict[str, Any]:
        out = {f.name: getattr(self, f.name) for f in fields(self)
               if f.name not in RUNNER_ADDED}
        out.update({name: r.as_dict() if r is not None else None for name, r in self.steps.items()})
        if self.navigation is not None:
            out.update({k: v for k, v in asdict(self.navigation).items()
                        if v is not None or k not in PLANNER_ONLY})
        for name in RUNNER_ADDED[2:]:
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


def tracking_metrics(s: RunSeries, range_max: float, period: float) -> dict[str, Any] | None:
    """The tracker's figures (twbr_tracker.evaluation) at the instants with both a track list and the
    world's, the robot where ground truth (or odom) had it then; None without a LiDAR run's two lists."""
    from twbr_tracker.evaluation import evaluate

    stamps = sorted(set(s.tracked) & set(s.truth_obstacles))
    if not stamps or not len(s.odom_t):
        return None
    instants = ((t, s.tracked[t], s.truth_obstacles[t],
                 (float(np.interp(t, s.odom_t, s.x_c)), float(np.interp(t, s.odom_t, s.y_c)))) for t in stamps)
    out = evaluate(instants, range_max, period=period).as_dict()
    # The fused target's error from its first sighting on (before it, a prior says only where it started)
    truth = dict(zip(s.target_t.tolist(), s.target_xy.tolist(), strict=True))
    errors = [math.dist(xy, truth[t]) for t, xy in zip(s.tracked_target_t.tolist(), s.tracked_target_xy.tolist(),
                                                       strict=True) if t in truth and t >= s.target_first_seen]
    out.update(target_estimates=len(errors), target_position_rmse_m=_finite(_rms(np.array(errors))),
               target_error_p95_m=float(np.percentile(errors, 95)) if errors else None,
               target_first_seen_s=_finite(s.target_first_seen))
    return out


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
    jolt = max((float(np.abs(np.diff(c[wheel])).max()) for wheel in ("left_torque", "right_torque")
                if len(c[wheel]) > 1), default=0.0)
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
        torque_step_max_nm=jolt,
        torque_saturated_samples=int(c["torque_saturated"].sum()),
        cmd_vel_stale_samples=int(c["cmd_vel_stale"].sum()),
        collision_limited_samples=int(c["collision_limited"].sum()),
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
