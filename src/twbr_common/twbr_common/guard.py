"""Admission of stamped inputs: what may reach the physics, the motors or a controller.

A message is refused when a value is NaN/inf, when it has no stamp (zero, once the clock is past the
timeout: at sim time 0 a zero stamp is a real one), when its stamp is already older than the timeout
(stale on arrival), or when its stamp is older than the last one accepted (out of order). An input not
refreshed within its timeout is stale, and the caller then falls back to its safe value (zero torque,
zero velocity). Stamps and `now` are seconds of the same clock (sim time in simulation). Pure Python.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from enum import Enum


class Verdict(Enum):
    ACCEPTED = "accepted"
    NON_FINITE = "non-finite value"
    UNSTAMPED = "no stamp"
    STALE = "stamp older than the timeout"
    OUT_OF_ORDER = "stamp older than the last accepted"


class InputGuard:
    """Tracks one input stream: the last accepted stamp, when it arrived, and what was refused."""

    def __init__(self, timeout: float, require_stamp: bool = True) -> None:
        if not timeout > 0.0:
            raise ValueError("timeout must be > 0")
        self.timeout = timeout
        self.require_stamp = require_stamp
        self.last_stamp: float | None = None
        self.last_receipt: float | None = None
        self.rejected: Counter[Verdict] = Counter()

    def offer(self, stamp: float, values: Iterable[float], now: float) -> Verdict:
        """Judge a message stamped `stamp` received at `now` (both in seconds of the node's clock)."""
        verdict = self._judge(stamp, values, now)
        if verdict is Verdict.ACCEPTED:
            self.last_stamp = stamp
            self.last_receipt = now
        else:
            self.rejected[verdict] += 1
        return verdict

    def _judge(self, stamp: float, values: Iterable[float], now: float) -> Verdict:
        if not all(math.isfinite(v) for v in values):
            return Verdict.NON_FINITE
        if self.require_stamp:
            if stamp <= 0.0 and now > self.timeout:
                return Verdict.UNSTAMPED
            if now - stamp > self.timeout:
                return Verdict.STALE
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
