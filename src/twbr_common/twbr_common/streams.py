"""The guarded inputs of one node: a guard per stream, one drop report, and restarts on a clock jump.

A clock that goes back (a restarted simulator, a bag replayed from its start) starts every stream of the
node afresh at once, not only the stream that noticed it: a cmd_vel received before the jump must be
stale after it, and the node's own schedules (the planner's rate, the controller's pairing) restart with
it through the hooks. Pure Python.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import numpy as np

from twbr_common.guard import DropReport, InputGuard


class InputStreams:
    def __init__(self, warn: Callable[[str], None], future_tolerance: float) -> None:
        self.drops = DropReport(warn)
        self.future_tolerance = future_tolerance
        self.guards: dict[str, InputGuard] = {}
        self.restarts = 0
        self._hooks: list[Callable[[], None]] = []
        self._latest: float | None = None

    def add(self, stream: str, timeout: float, require_stamp: bool = True, limit: float = math.inf) -> InputGuard:
        guard = InputGuard(timeout, require_stamp, limit, self.future_tolerance if require_stamp else math.inf)
        self.guards[stream] = guard
        return guard

    def on_restart(self, hook: Callable[[], None]) -> None:
        self._hooks.append(hook)

    def observe(self, now: float) -> None:
        """Note the node's clock, and restart everything when it went back."""
        jumped = self._latest is not None and now < self._latest
        self._latest = now
        if jumped:
            self.restart()

    def restart(self) -> None:
        self.restarts += 1
        self._latest = None
        for guard in self.guards.values():
            guard.reset()
        for hook in self._hooks:
            hook()

    def admit(self, stream: str, stamp: float, values: Iterable[float], now: float) -> bool:
        self.observe(now)
        return self.drops.admit(self.guards[stream], stream, stamp, values, now)

    def dropped(self, stream: str, reason: str, detail: str = "") -> None:
        self.drops.dropped(stream, reason, detail)

    def admit_obstacles(self, data: bytes, now: float) -> tuple[float, np.ndarray] | None:
        """A serialized twbr_msgs/ObstacleArray on the stream "obstacles": (its stamp [s], rows of id, x, y,
        vx, vy, radius) when admitted; None when refused (counted and warned about, as every input)."""
        from twbr_common.cdr import obstacle_rows

        obstacles = obstacle_rows(data)
        if obstacles is None:
            self.dropped("obstacles", "not a twbr_msgs/ObstacleArray")
            return None
        stamp, rows = obstacles.stamp.sec + obstacles.stamp.nanosec * 1e-9, obstacles.rows
        if (rows[:, 5] < 0.0).any():
            self.dropped("obstacles", "negative radius")
            return None
        return (stamp, rows) if self.admit("obstacles", stamp, rows[:, 1:], now) else None
