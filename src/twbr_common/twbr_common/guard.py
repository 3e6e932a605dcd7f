"""Admission of stamped inputs: what may reach the physics, the motors or a controller.

A message is refused when a value is NaN/inf or absurdly large (past the stream's `limit`), when it has
no stamp (zero, once the clock is past the timeout: at sim time 0 a zero stamp is a real one), when its
stamp is already older than the timeout (stale on arrival), when its stamp is ahead of the node's clock by
more than `future_tolerance` (a driver with an unsynchronised clock, wall time on a sim-time graph: accepted,
it would make every real message after it look out of order), or when its stamp is older than the last one
accepted (out of order). An input not refreshed within its timeout is stale, and the caller then falls
back to its safe value (zero torque, zero velocity). Stamps and `now` are seconds of the same clock (sim
time in simulation). Pure Python.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Iterable
from enum import Enum

import numpy as np

from twbr_common.params import ParamSpec

# Largest magnitudes a stream's values may have (SI units). Far past anything a balancing robot does, so
# only garbage (a unit mix-up, uninitialised memory, a corrupted message) is refused, never a hard manoeuvre.
RATE_LIMIT = 100.0  # speeds, angular rates and angles [m/s, rad/s, rad]
POSITION_LIMIT = 1e5  # positions and distances [m]
TORQUE_LIMIT = 1e3  # wheel torques [N·m]: the top of the controller's max_wheel_torque range

# How far ahead of the node's clock a stamp may be, when the parameter says "auto" (negative). On wall time,
# clocks of separate machines agree to a few ms with NTP/PTP, and 0.1 s refuses only an unsynchronised one.
# On sim time the clock is the simulator's own, sent just before each state; but DDS does not order two
# topics, and about one state in 5000 reaches a node before the /clock that announces it (measured): one
# 200 Hz state period plus a margin admits that state, and nothing further ahead. A node outside the
# lockstep that works for milliseconds on a scan (tracker_node) takes the states queued meanwhile in a
# burst, and an odom then came up to two states ahead of its /clock (19 refused over 25 LiDAR runs, one of
# them a scan's own odom: the scan placed with the state before it): such a node takes SLOW_SIM_FUTURE_TOLERANCE.
WALL_FUTURE_TOLERANCE = 0.1
SIM_FUTURE_TOLERANCE = 0.006
SLOW_SIM_FUTURE_TOLERANCE = 0.05


def input_specs(sim_tolerance: float = SIM_FUTURE_TOLERANCE) -> tuple[ParamSpec, ...]:
    """A node's input parameters, `sim_tolerance` [s] its future_tolerance on sim time by default."""
    return (
        ParamSpec("future_tolerance", -1.0, "an input stamped more than this ahead of the node's clock is dropped"
                  f" and counted; negative: {WALL_FUTURE_TOLERANCE:g} s on wall time, {sim_tolerance:g} s on"
                  " sim time", "s", -1.0, 60.0),
    )


INPUT_SPECS = input_specs()


def future_tolerance(value: float, sim_time: bool, sim_default: float = SIM_FUTURE_TOLERANCE) -> float:
    """The tolerance a node uses: the parameter, or its clock's default when the parameter is negative."""
    if value >= 0.0:
        return value
    return sim_default if sim_time else WALL_FUTURE_TOLERANCE


class Verdict(Enum):
    ACCEPTED = "accepted"
    NON_FINITE = "non-finite value"
    IMPLAUSIBLE = "absurdly large value"
    UNSTAMPED = "no stamp"
    STALE = "stamp older than the timeout"
    FUTURE = "stamp ahead of the clock"
    OUT_OF_ORDER = "stamp older than the last accepted"


class InputGuard:
    """Tracks one input stream: the last accepted stamp, when it arrived, and what was refused."""

    def __init__(self, timeout: float, require_stamp: bool = True, limit: float = math.inf,
                 future_tolerance: float = math.inf) -> None:
        if not timeout > 0.0:
            raise ValueError("timeout must be > 0")
        if not future_tolerance >= 0.0:
            raise ValueError("future_tolerance must be >= 0")
        self.timeout = timeout
        self.require_stamp = require_stamp
        self.limit = limit
        self.future_tolerance = future_tolerance
        self.last_stamp: float | None = None
        self.last_receipt: float | None = None
        self.rejected: Counter[Verdict] = Counter()
        self.clock_jumps = 0

    def offer(self, stamp: float, values: Iterable[float] | np.ndarray, now: float) -> Verdict:
        """Judge a message stamped `stamp` received at `now` (both in seconds of the node's clock).

        The node's own clock going back (a restarted simulator, a bag replayed from its start) starts the
        stream afresh; a message cannot move that clock, so an old stamp alone is still refused.
        """
        if self.last_receipt is not None and now < self.last_receipt:
            self.reset()
            self.clock_jumps += 1
        verdict = self._judge(stamp, values, now)
        if verdict is Verdict.ACCEPTED:
            self.last_stamp = stamp
            self.last_receipt = now
        else:
            self.rejected[verdict] += 1
        return verdict

    def _judge(self, stamp: float, values: Iterable[float] | np.ndarray, now: float) -> Verdict:
        # The stamp first: it is one number, and a flood of large messages with bad stamps (an obstacle
        # array of 5,000 entries 48 times a second) is refused without reading its values.
        verdict = self._judge_stamp(stamp, now)
        if verdict is not Verdict.ACCEPTED:
            return verdict
        if isinstance(values, np.ndarray):
            if not np.isfinite(values).all():
                return Verdict.NON_FINITE
            if values.size and np.abs(values).max() > self.limit:
                return Verdict.IMPLAUSIBLE
            return Verdict.ACCEPTED
        values = tuple(values)
        if not all(math.isfinite(v) for v in values):
            return Verdict.NON_FINITE
        if any(abs(v) > self.limit for v in values):
            return Verdict.IMPLAUSIBLE
        return Verdict.ACCEPTED

    def _judge_stamp(self, stamp: float, now: float) -> Verdict:
        """The stamp's rules alone (no stamp, stale, ahead of the clock, out of order)."""
        if self.require_stamp:
            if stamp <= 0.0 and now > self.timeout:
                return Verdict.UNSTAMPED
            if now - stamp > self.timeout:
                return Verdict.STALE
            if stamp - now > self.future_tolerance:
                return Verdict.FUTURE
        if self.last_stamp is not None and stamp < self.last_stamp:
            return Verdict.OUT_OF_ORDER
        return Verdict.ACCEPTED

    def is_stale(self, now: float) -> bool:
        """True before the first accepted message, and when the last one is older than the timeout."""
        return self.last_receipt is None or (now - self.last_receipt) > self.timeout

    @property
    def rejected_total(self) -> int:
        return sum(self.rejected.values())

    def reset(self) -> None:
        """Forget the stream (after a clock jump back, e.g. a replayed bag restarting)."""
        self.last_stamp = None
        self.last_receipt = None


class DropReport:
    """Warns about refused messages at most once per `period` per stream, with the count since the last warning
    by reason.

    rclpy's own throttle is per call site, so one noisy stream would hide the others behind a shared line;
    and the reason of the one message that triggers a warning alone would hide every other kind of fault.
    """

    def __init__(self, warn: Callable[[str], None], period: float = 1.0) -> None:
        self._warn = warn
        self.period = period
        self._last: dict[str, float] = {}
        self._pending: dict[str, Counter[str]] = {}

    def admit(self, guard: InputGuard, stream: str, stamp: float, values: Iterable[float], now: float) -> bool:
        """Offer a message to its stream's guard; warn (throttled) when it is refused."""
        verdict = guard.offer(stamp, values, now)
        if verdict is Verdict.ACCEPTED:
            return True
        self.dropped(stream, verdict.value)
        return False

    def dropped(self, stream: str, reason: str, detail: str = "") -> None:
        """Count a refused message by `reason` (one of a few kinds); `detail` (its values) goes into the
        warning only when this message is the one that triggers it, so a line stays one short line."""
        reasons = self._pending.setdefault(stream, Counter())
        reasons[reason] += 1
        now = time.monotonic()
        if now - self._last.get(stream, -math.inf) >= self.period:
            self._last[stream] = now
            del self._pending[stream]
            n = reasons.total()
            kinds = ", ".join(f"{k} {r}" for r, k in reasons.most_common())
            shown = f" ({detail})" if detail else ""
            self._warn(f"dropped {stream}: {reason}{shown}" + (f"; {n} dropped since the last warning: {kinds}"
                                                                if n > 1 else ""))
