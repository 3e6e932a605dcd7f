"""The robot's recent poses by stamp, so a scan is placed with the odom of its own instant.

A scan and its odom travel on separate topics, and the executor may hand the tracker several odoms before
the scan that came first. Placing the scan with the newest odom would move it by however far the robot
drove in between, by how loaded the machine is: a lockstep run would no longer be the same loaded or idle.
So the poses of the last `odom_history` seconds are kept, as tf2's buffer keeps transforms, and a scan gets
the first odom stamped at or after it wherever that falls in the arrival order.
"""

from __future__ import annotations

import bisect
import math
from collections import deque

from twbr_common.params import ParamSpec

POSE_HISTORY_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("odom_history", 2.0, "odoms are kept this long, so a scan that arrives after later odoms is still"
              " placed with its own instant's", "s", 0.01, 60.0),
)


class PoseHistory:
    """Odoms in stamp order, each (stamp, *pose); the oldest drop out `span` seconds behind the newest."""

    def __init__(self, span: float) -> None:
        self.span = span
        self._poses: deque[tuple[float, ...]] = deque()
        self._forgotten = -math.inf  # the newest stamp that fell out: before it, "the first at or after" is lost

    def add(self, stamp: float, *pose: float) -> None:
        """An odom newer than every one so far (the input guard refuses the others)."""
        self._poses.append((stamp, *pose))
        while self._poses[0][0] < stamp - self.span:
            self._forgotten = self._poses.popleft()[0]

    def newest(self) -> float:
        """The newest odom's stamp (-inf before the first)."""
        return self._poses[-1][0] if self._poses else -math.inf

    def at_or_after(self, t: float) -> tuple[float, ...] | None:
        """The first odom stamped at or after `t`; None when there is none yet, or when it has been forgotten
        (`t` is older than the history)."""
        if t <= self._forgotten:
            return None
        i = bisect.bisect_left(self._poses, t, key=lambda p: p[0])
        return self._poses[i] if i < len(self._poses) else None

    def __len__(self) -> int:
        return len(self._poses)

    def clear(self) -> None:
        self._poses.clear()
        self._forgotten = -math.inf
