"""When a rate is due: one rule for every decimated loop (the simulator's publications, the planner's
instants, the headless closed loop and the batch engine's planner and world).

A rate keeps its grid (due_at, due_at + period, ...), so float sums of periods never drift the instants;
an instant counts as reached up to SLACK early, the resolution of a stamp; a call that comes a whole
period late (a stall) restarts the grid from the call instead of queueing a burst of due instants.
"""

from __future__ import annotations

from twbr_common.jit import kernel

SLACK = 1e-9  # [s] one nanosecond, a stamp's resolution


@kernel
def is_due(t: float, due_at: float) -> bool:
    """Whether time t [s] has reached the instant due_at [s] (-inf: the first call)."""
    return t + SLACK >= due_at


@kernel
def next_due(t: float, due_at: float, period: float) -> float:
    """The instant after the due instant due_at, reached at t: the next on the grid, or t + period after a stall."""
    following = due_at + period
    return following if following > t + SLACK else t + period


@kernel
def takes_effect(command_stamp: float, state_stamp: float) -> bool:
    """Whether a command stamped command_stamp [s] applies to the state stamped state_stamp [s]: from the
    first state stamped after it, so whether the answer to a state arrives just before or just after the
    next state's message never changes the command computed for it (state_sync.VelocityCommand, the batch
    engine)."""
    return command_stamp < state_stamp


# The same functions run by the interpreter: a node's Python loop calls them several times per state,
# where a call through the compiled dispatcher costs several times the arithmetic.
_is_due = getattr(is_due, "py_func", is_due)
_next_due = getattr(next_due, "py_func", next_due)
takes_effect_interpreted = getattr(takes_effect, "py_func", takes_effect)


class Decimator:
    """`due(t)` is true once per period of sim or wall time t, by is_due/next_due; a time earlier than the
    last due instant (a restarted simulator) restarts the schedule."""

    def __init__(self, rate: float) -> None:
        if not rate > 0.0:
            raise ValueError("rate must be > 0")
        self.period = 1.0 / rate
        self.restart()

    def restart(self) -> None:
        self._next = float("-inf")
        self._last: float | None = None

    def _jumped_back(self, t: float) -> bool:
        return self._last is not None and t < self._last

    def would_be_due(self, t: float) -> bool:
        """What due(t) would answer, without taking the instant."""
        return self._jumped_back(t) or _is_due(t, self._next)

    def due(self, t: float) -> bool:
        if self._jumped_back(t):
            self.restart()
        if not _is_due(t, self._next):
            return False
        self._next = _next_due(t, self._next, self.period)
        self._last = t
        return True
