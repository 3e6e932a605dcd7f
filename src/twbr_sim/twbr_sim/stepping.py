"""How sim_node steps, without ROS: what lockstep waits for, what realtime does at each tick, what is due.

sim_node is a thin adapter around these: it spins its executor until `LockstepExchange.answered` or the
wall-clock deadline, and asks `RealtimeTicks` when to publish telemetry, when to step and when to send;
`Publications` says which decimated topics go out with a state. Times here are plain floats: sim time [s]
for what is due, `time.monotonic()` [s] for the realtime schedule.
"""

from __future__ import annotations

from enum import Enum
from typing import NamedTuple

from twbr_common.timing import Decimator


class Missing(Enum):
    COMMAND = "wheel_torque_cmd"
    PLANNER = "planner_state"
    SCRIPTED = "cmd_vel"


class TimeoutAction(Enum):
    OFFER_AGAIN = "offer_again"  # nobody has answered the first state yet: hold t = 0 and offer it again
    STEP_ON = "step_on"  # a lockstep timeout: counted, and the simulator steps without the answer


# A scripted profile's command not heard for this long [s of sim time] is awaited again at the next state
# with a clock: half the controller's default cmd_vel_timeout, so a player starved on a loaded host never
# lets the controller's command go stale (it re-publishes at 20 Hz of /clock; idle, it is never awaited).
SCRIPT_QUIET_NS = 250_000_000


class LockstepExchange:
    """The answers the pending state awaits: the command stamped with it, and at every `planner_every`-th
    physics step the planner's output stamped with it too (0: the planner is not waited for), and where a
    scripted cmd_vel profile changes, or has not been heard for SCRIPT_QUIET_NS, the profile's command seen
    on cmd_vel (`expected`: unstamped, it is known by its value).

    Only an answer stamped with the pending state counts: a late one, or one from a stray publisher,
    never stands in for the answer to the state the simulator holds.
    """

    def __init__(self, planner_every: int = 0, wait_for_first_command: bool = True) -> None:
        self.planner_every = planner_every
        self.waiting_first = wait_for_first_command
        self.pending_ns: int | None = None
        self._step_count = 0
        self.command_matched = False
        self._planner_ns: int | None = None
        self.expected: tuple[float, float] | None = None
        self._expected_seen = False
        self._heard: tuple[tuple[float, float], int] | None = None
        self._player_gone = False  # a keep-alive awaited in vain: not awaited again until the player is heard

    def offered(self, stamp_ns: int, step_count: int, expected: tuple[float, float] | None = None) -> None:
        """A state stamped `stamp_ns` at physics step `step_count` went out: its answers are awaited, and
        the scripted command `expected` (v, omega) on cmd_vel, when the profile changes at this state."""
        self.pending_ns = stamp_ns
        self._step_count = step_count
        self.command_matched = False
        self.expected = expected
        self._expected_seen = False

    def scripted(self, command: tuple[float, float]) -> None:
        """A cmd_vel (v, omega) seen: the awaited one if it is the profile's value."""
        if self.expected is not None and command == self.expected:
            self._expected_seen = True
        if self.pending_ns is not None:
            self._heard = (command, self.pending_ns)
        self._player_gone = False

    def script_quiet(self, command: tuple[float, float], stamp_ns: int) -> bool:
        """True when `command` was last heard SCRIPT_QUIET_NS or more before the state stamped `stamp_ns`
        (heard while that earlier state was pending), or never; false once a keep-alive was awaited in vain, so
        a player that died costs one lockstep timeout, not one per clock."""
        if self._player_gone:
            return False
        return self._heard is None or self._heard[0] != command or stamp_ns - self._heard[1] >= SCRIPT_QUIET_NS

    def command(self, stamp_ns: int) -> bool:
        """An admitted command stamped `stamp_ns`; true when it is the first answer to the pending state."""
        if self.pending_ns is None or stamp_ns != self.pending_ns or self.command_matched:
            return False
        self.command_matched = True
        return True

    def planner(self, stamp_ns: int) -> None:
        if stamp_ns == self.pending_ns:
            self._planner_ns = stamp_ns

    @property
    def planner_due(self) -> bool:
        return bool(self.planner_every) and self._step_count % self.planner_every == 0

    def answered(self) -> bool:
        if not self.command_matched or (self.expected is not None and not self._expected_seen):
            return False
        return self._planner_ns == self.pending_ns if self.planner_due else True

    def missing(self) -> Missing:
        if not self.command_matched:
            return Missing.COMMAND
        return Missing.SCRIPTED if self.expected is not None and not self._expected_seen else Missing.PLANNER

    def timed_out(self) -> TimeoutAction:
        """The wall-clock wait ran out without the answers: what to do."""
        if self.waiting_first and self._step_count == 0:
            return TimeoutAction.OFFER_AGAIN
        return TimeoutAction.STEP_ON

    def stepping(self) -> None:
        """The simulator steps past the pending state: from now on a missing answer is a timeout, and a
        scripted command it stepped without is not awaited again until the player is heard."""
        self.waiting_first = False
        if self.missing() is Missing.SCRIPTED:
            self._player_gone = True


class RealtimeTicks:
    """The realtime loop's schedule: the state goes out at each tick, telemetry once the answer is in (at
    most half a period later), and the next state is stepped and filled as soon as the answer is in, to
    be sent at its tick.

    A real driver serves its control loop first: telemetry published before the answer is handled would
    delay it. Without an answer by the tick, the step waits for the tick (a late command still counts).
    After a stall the ticks keep their schedule but never try to catch up more than one period.
    """

    def __init__(self, period: float, now: float) -> None:
        self.period = period
        self.telemetry_by: float | None = now + 0.5 * period
        self.next_tick = now + period
        self.prepared = False

    def telemetry_due(self, answered: bool, now: float) -> bool:
        return self.telemetry_by is not None and (answered or now >= self.telemetry_by)

    def telemetry_done(self) -> None:
        self.telemetry_by = None

    def wake_at(self) -> float:
        """When the loop must look again (it wakes earlier for any message)."""
        return self.next_tick if self.telemetry_by is None else self.telemetry_by

    def tick_due(self, now: float) -> bool:
        return now >= self.next_tick

    def sent(self, now: float) -> None:
        """The state went out at `now`: telemetry by half a period later, the next tick one period on."""
        self.prepared = False
        self.telemetry_by = now + 0.5 * self.period
        self.next_tick = max(self.next_tick + self.period, now - self.period)


class StateTopics(NamedTuple):
    clock: bool
    world: bool
    scan: bool
    detections: bool


class StateTelemetryTopics(NamedTuple):
    tf: bool
    markers: bool


class Publications:
    """Which decimated topics go out at sim time t: /clock, the world, the scan and the target detections
    with the state (before odom: a planner, or a tracker feeding one, has them for the instant it answers), /tf, sim_status (also
    whenever a flag changes) and the markers with telemetry."""

    def __init__(self, clock_rate: float, world_rate: float, tf_rate: float, marker_rate: float,
                 scan_rate: float = 0.0, detection_rate: float = 0.0) -> None:
        self._clock = Decimator(clock_rate)
        self._world = Decimator(world_rate)
        self._tf = Decimator(tf_rate)
        self._status = Decimator(world_rate)
        self._markers = Decimator(marker_rate)
        self._scan = Decimator(scan_rate) if scan_rate > 0.0 else None  # 0: no scan topic
        self._detections = Decimator(detection_rate) if detection_rate > 0.0 else None  # 0: no target sensor

    def with_state(self, t: float, hosting_world: bool) -> StateTopics:
        clock = self._clock.due(t)
        return StateTopics(clock, hosting_world and self._world.due(t), self._scan is not None and self._scan.due(t),
                           self._detections is not None and self._detections.due(t))

    def with_state_telemetry(self, t: float, hosting_world: bool) -> StateTelemetryTopics:
        return StateTelemetryTopics(self._tf.due(t), hosting_world and self._markers.due(t))

    def status_due(self, t: float, flags_changed: bool) -> bool:
        return self._status.due(t) or flags_changed
