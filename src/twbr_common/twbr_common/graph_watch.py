"""Neighbours on the graph: a second publisher on a topic a node owns, or a publisher of the wrong type.

Two graphs started on one ROS_DOMAIN_ID mix silently: a second simulator's odom and /clock reach the
first graph's controller, which then answers two robots. DDS cannot refuse them, but a node can see them
in the graph and say so at error level, naming the other node. Checked once a second (wall time), and each
finding is reported once until it changes.
"""

from __future__ import annotations

from collections.abc import Iterable

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

SECOND_PUBLISHER = "a second publisher on "
WRONG_TYPE = "a publisher of "
FINDING_MARKS = (SECOND_PUBLISHER, WRONG_TYPE)  # how each finding begins (the runner reads them in node logs)


def _type_name(msg_class: type) -> str:
    module = msg_class.__module__.split(".")[0]
    return f"{module}/msg/{msg_class.__name__}"


class GraphWatch:
    def __init__(self, node: Node, owned: Iterable[str], period: float = 1.0) -> None:
        self.node = node
        self.owned = [node.resolve_topic_name(t) for t in owned]
        self._reported: set[str] = set()
        # Wall time: a node on sim time has no clock while nothing publishes /clock, and is watched all the same.
        node.create_timer(period, self.check, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _topics(self) -> dict[str, str]:
        """Every topic this node publishes or subscribes, with its type."""
        out = {}
        for entity in (*self.node.publishers, *self.node.subscriptions):
            out[entity.topic_name] = _type_name(entity.msg_type)
        return out

    def check(self) -> list[str]:
        try:
            found = self._find()
        except Exception:
            if self.node.context.ok():
                raise
            return []  # shutting down (a signal during the query): nothing to report
        for line in found:
            if line not in self._reported:
                self.node.get_logger().error(line)
        self._reported = set(found)
        return found

    def _find(self) -> list[str]:
        node = self.node
        found = []
        for topic, ours in self._topics().items():
            publishers = node.get_publishers_info_by_topic(topic)
            for p in publishers:
                if p.topic_type != ours:
                    found.append(f"{WRONG_TYPE}{p.topic_type} on {topic} ({_who(p)}): the contract's type is"
                                 f" {ours} and its messages cannot reach this node")
            if topic in self.owned:
                # Counted, not named: a second graph's node has the same name as this one.
                mine = sum(1 for pub in node.publishers if pub.topic_name == topic)
                same_type = [p for p in publishers if p.topic_type == ours]
                if len(same_type) > mine:
                    who = ", ".join(sorted({_who(p) for p in same_type}))
                    found.append(f"{SECOND_PUBLISHER}{topic}, which this node owns ({len(same_type) - mine} more,"
                                 f" from {who}): another graph on this ROS_DOMAIN_ID? Nodes reading {topic} now"
                                 " mix two sources")
        return found


def _who(info) -> str:
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"
