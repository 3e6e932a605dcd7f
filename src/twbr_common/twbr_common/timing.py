"""Decimation of a fast loop into slower publications (tf, world topics, markers) and plans."""

from __future__ import annotations


class Decimator:
    """`due(t)` is true once per period of sim or wall time t; a late call does not queue up a burst, and a
    time earlier than the last due instant (a restarted simulator) restarts the schedule."""

    def __init__(self, rate: float) -> None:
        if not rate > 0.0:
            raise ValueError("rate must be > 0")
        self.period = 1.0 / rate
        self.restart()

    def restart(self) -> None:
        self._next: float | None = None
        self._last: float | None = None

    def due(self, t: float) -> bool:
        if self._last is not None and t < self._last:
            self.restart()
        if self._next is not None and t + 1e-12 < self._next:
            return False
        if self._next is None or self._next + self.period <= t:
            self._next = t + self.period  # first call, or after a stall: restart the schedule from now
        else:
            self._next += self.period
        self._last = t
        return True
