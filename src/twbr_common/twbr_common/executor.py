"""The executor every node spins: rclpy's EventsExecutor where this rclpy has it.

SingleThreadedExecutor rebuilds its wait set in Python on every wake-up. The EventsExecutor (rclpy
7.1.5+, `rclpy.experimental`) dispatches each message from C++ as it arrives, which more than halves the
state -> command round trip (benchmarks/README.md has the figures).

Callbacks run in the order their messages arrived, not in the order their subscriptions were created.
TWBR_EXECUTOR=single selects SingleThreadedExecutor, for an rclpy without the EventsExecutor or to rule
it out while chasing a bug.
"""

from __future__ import annotations

import signal

import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor

from twbr_common.params import env_choice

ENV = "TWBR_EXECUTOR"
CHOICES = ("events", "single")


def executor_kind() -> str:
    return env_choice(ENV, CHOICES, "events")


def new_executor(context: Context | None = None) -> Executor:
    if executor_kind() == "events":
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError:  # an rclpy before the EventsExecutor
            pass
        else:
            return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


class StopSignals:
    """SIGINT/SIGTERM noted, with the context still up (rclpy initialised without its own handlers, which
    would shut the context down at once): what the node took or published last can still be handled then,
    a recorder's last messages, or a publisher's samples a lagging subscriber has not acknowledged yet."""

    def __init__(self) -> None:
        self.received: int | None = None
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self._handle)

    def _handle(self, signum: int, _frame) -> None:
        self.received = signum


def spin_until_shutdown(node: rclpy.node.Node, poll: float = 0.5, stop: StopSignals | None = None) -> None:
    """Spin `node` until its context shuts down (Ctrl-C, SIGTERM, rclpy.shutdown), or until `stop` notes a
    signal (looked at every `poll` s at most).

    spin_once in a loop rather than spin(): with the rclpy 7.1.6 wheels, the EventsExecutor's spin()
    dispatched no subscription callback at all in our check (0 of 27 messages; spin_once: 27 of 27).
    """
    executor = new_executor(node.context)
    executor.add_node(node)
    try:
        while node.context.ok() and (stop is None or stop.received is None):
            executor.spin_once(timeout_sec=poll)
    finally:
        executor.remove_node(node)
        executor.shutdown()
