"""The executor every node spins: rclpy's EventsExecutor where this rclpy has it.

SingleThreadedExecutor rebuilds its wait set in Python on every wake-up. The EventsExecutor (rclpy
7.1.5+, `rclpy.experimental`) dispatches each message from C++ as it arrives, which more than halves the
state -> command round trip (benchmarks/README.md has the figures).

Callbacks run in the order their messages arrived, not in the order their subscriptions were created.
TWBR_EXECUTOR=single selects SingleThreadedExecutor, for an rclpy without the EventsExecutor or to rule
it out while chasing a bug.
"""

from __future__ import annotations

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


def spin_until_shutdown(node: rclpy.node.Node, poll: float = 0.5) -> None:
    """Spin `node` until its context shuts down (Ctrl-C, SIGTERM, rclpy.shutdown).

    spin_once in a loop rather than spin(): with the rclpy 7.1.6 wheels, the EventsExecutor's spin()
    dispatched no subscription callback at all in our check (0 of 27 messages; spin_once: 27 of 27).
    """
    executor = new_executor(node.context)
    executor.add_node(node)
    try:
        while node.context.ok():
            executor.spin_once(timeout_sec=poll)
    finally:
        executor.remove_node(node)
        executor.shutdown()
