"""Pairs odom and imu samples into one robot state, and decides when a state is due for control.

The speed and yaw rate come from odom, the pitch and its rate from the IMU. A state is formed only from
an odom and an imu stamped within `tolerance` of each other (the simulator stamps both alike), so the
controller never mixes a new pitch with an old speed and is deterministic in lockstep. A state is due
once per control period of its stamps; the same state offered again (a lockstep simulator re-offering
its first state) asks for the same command again, which is what lets a late-starting graph begin.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from twbr_common.timing import takes_effect_interpreted


@dataclass(frozen=True)
class RobotState:
    stamp: float  # [s], the newer of the two stamps
    velocity: float  # [m/s]
    yaw_rate: float  # [rad/s]
    pitch: float  # [rad]
    pitch_rate: float  # [rad/s]


class Action(Enum):
    WAIT = "wait"  # no complete state, or not due yet
    COMPUTE = "compute"  # a new state is due: compute and send a command
    REPEAT = "repeat"  # the state last computed was offered again: send the same command again


class StateSync:
    def __init__(self, rate: float, tolerance: float) -> None:
        self.period = 1.0 / rate
        self.tolerance = tolerance
        self.reset()

    def reset(self) -> None:
        """Forget every sample and the schedule (a restarted clock): the next complete state computes."""
        self._odom: tuple[float, float, float] | None = None
        self._imu: tuple[float, float, float, float | None] | None = None
        self.last_stamp: float | None = None
        self._next_due: float | None = None

    @property
    def newest_stamp(self) -> float:
        """The newest stamp of an odom or imu sample offered since the last reset (-inf before any)."""
        stamps = [sample[0] for sample in (self._odom, self._imu) if sample is not None]
        return max(stamps, default=float("-inf"))

    def offer_odom(self, stamp: float, velocity: float, yaw_rate: float) -> tuple[Action, RobotState | None]:
        self._odom = (stamp, velocity, yaw_rate)
        return self._decide()

    def offer_imu(self, stamp: float, pitch: float, pitch_rate: float,
                  velocity: float | None = None) -> tuple[Action, RobotState | None]:
        """`velocity` [m/s], when given, replaces odom's speed in the state (an estimator's, fused from both)."""
        self._imu = (stamp, pitch, pitch_rate, velocity)
        return self._decide()

    def _decide(self) -> tuple[Action, RobotState | None]:
        if self._odom is None or self._imu is None:
            return Action.WAIT, None
        t_odom, velocity, yaw_rate = self._odom
        t_imu, pitch, pitch_rate, fused = self._imu
        velocity = velocity if fused is None else fused
        if abs(t_odom - t_imu) > self.tolerance + 1e-12:
            return Action.WAIT, None
        stamp = max(t_odom, t_imu)
        state = RobotState(stamp, velocity, yaw_rate, pitch, pitch_rate)
        if self.last_stamp is not None and stamp == self.last_stamp:
            return Action.REPEAT, state
        if self.last_stamp is not None and stamp < self.last_stamp:
            return Action.WAIT, None  # an older pair completed late: the command for a newer one is out
        if self._next_due is not None and stamp < self._next_due - 0.25 * self.period:
            return Action.WAIT, None
        # Keep the schedule (jittery stamps still give the set rate); restart it after a gap.
        if self._next_due is None or stamp > self._next_due + self.period:
            self._next_due = stamp + self.period
        else:
            self._next_due += self.period
        self.last_stamp = stamp
        return Action.COMPUTE, state


class VelocityCommand:
    """cmd_vel as the controller applies it: from the first state stamped after it, stale past the timeout.

    Whether the planner's answer to the state at t reaches the controller just before or just after that
    state's odom then never changes the command computed for it, so a lockstep run is the same on an idle
    and on a loaded machine. A cmd_vel received but not yet in effect cannot freshen a state either.
    """

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.reset()

    def reset(self) -> None:
        self._next: tuple[float, float, float] | None = None  # (stamp, v, omega) not yet in effect
        self._stamp: float | None = None  # the stamp of the one in effect
        self.since = 0.0  # [s] the stamp of the first state it applied to (the cascade's command_stamp)
        self._refs = (0.0, 0.0)

    def offer(self, stamp: float, velocity: float, yaw_rate: float) -> None:
        """An admitted cmd_vel stamped `stamp` [s] (for a plain Twist: its arrival on the node's clock)."""
        self._next = (stamp, velocity, yaw_rate)

    def at(self, stamp: float) -> tuple[float, float, bool]:
        """(v_ref [m/s], omega_ref [rad/s], stale) for the state stamped `stamp` [s]."""
        if self._next is not None and takes_effect_interpreted(self._next[0], stamp):
            self._stamp, *refs = self._next
            self.since = stamp
            self._refs = (refs[0], refs[1])
            self._next = None
        stale = self._stamp is None or stamp - self._stamp > self.timeout
        return (*self._refs, stale)
