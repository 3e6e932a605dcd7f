"""Neighbours on the graph: a second publisher on a topic a node owns, or a publisher of the wrong type.

Two graphs started on one ROS_DOMAIN_ID mix silently: a second simulator's odom and /clock reach the
first graph's controller, which then answers two robots. DDS cannot refuse them, but a node can see them
in the graph and say so at error level, naming the other node. Checked once a second (wall time), and each
finding is reported once until it changes.
"""

from __future__ import annotations

from collections.abc import Iterable

from rclpy.node import Node


def _type_name(msg_class: type) -> str:
    module = msg_class.__module__.split(".")[0]
    return f"{module}/msg/{msg_class.__name__}"


class GraphWatch:
    def __init__(self, node: Node, owned: Iterable[str], period: float = 1.0) -> None:
        self.node = node
        self.owned = [node.resolve_topic_name(t) for t in owned]
        self._reported: set[str] = set()
        self.findings: list[str] = []
        node.create_timer(period, self.check)

    def _topics(self) -> dict[str, str]:
        """Every topic this node publishes or subscribes, with its type."""
        out = {}
        for entity in (*self.node.publishers, *self.node.subscriptions):
            out[entity.topic_name] = _type_name(entity.msg_type)
        return out

    def check(self) -> list[str]:
        node = self.node
        me = (node.get_name(), node.get_namespace())
        found = []
        for topic, ours in self._topics().items():
            others = [p for p in node.get_publishers_info_by_topic(topic) if (p.node_name, p.node_namespace) != me]
            for p in others:
                who = f"{p.node_namespace.rstrip('/')}/{p.node_name}"
                if p.topic_type != ours:
                    found.append(f"a publisher of {p.topic_type} on {topic} ({who}): the contract's type is {ours}"
                                 " and its messages cannot reach this node")
                elif topic in self.owned:
                    found.append(f"a second publisher on {topic}, which this node owns: {who} (another graph on"
                                 " this ROS_DOMAIN_ID?); the nodes reading it now mix two sources")
        for line in found:
            if line not in self._reported:
                node.get_logger().error(line)
        self._reported = set(found)
        self.findings = found
        return found
