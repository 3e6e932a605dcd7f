"""QoS profiles of the interface contract, and stamp conversions."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

# Sensor streams (odom, imu, joint_states) are subscribed best effort: that matches reliable and
# best-effort publishers alike (real drivers differ). Our publishers of them are reliable, and keep the
# last STREAM_HISTORY samples to resend: a reliable recorder that the machine's load holds back catches
# up from them instead of losing what it missed. 100 (0.5 s of a 200 Hz stream, ~0.17 s of wall time at
# RTF 3) lost 0.8 s of every stream at once in a bag when two graphs and two busy loops shared 2 cores;
# 1000 keeps ~1.7 s of wall time. Keeping them costs memory (~1 MB a stream), never the publisher's time.
STREAM_HISTORY = 1000
RECORDED_PUB_QOS = QoSProfile(depth=STREAM_HISTORY, reliability=ReliabilityPolicy.RELIABLE)
SENSOR_SUB_QOS = qos_profile_sensor_data
SENSOR_PUB_QOS = CLOCK_PUB_QOS = RECORDED_PUB_QOS
# Commands and world topics are reliable. Subscribers keep 10 (they want the newest); publishers keep
# STREAM_HISTORY for the same reason as the streams (docs/interfaces.md, QoS). Markers are drawn, not
# measured: they keep 10.
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
WORLD_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
COMMAND_PUB_QOS = WORLD_PUB_QOS = RECORDED_PUB_QOS
MARKER_QOS = WORLD_QOS
# /tf_static, as tf2_ros' StaticTransformBroadcaster: a late subscriber still gets the transforms.
TF_STATIC_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)


def to_stamp(nanoseconds: int) -> Time:
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def stamp_ns(stamp: Time) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def stamp_seconds(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def flush_publishers(node: Node, timeout_s: float = 1.0) -> bool:
    """Wait until reliable subscribers have acknowledged everything published.

    A process that exits right after its last publish would otherwise drop the final samples
    (the last state of a run, the final status) that recorders and tests rely on.
    """
    deadline = Duration(seconds=timeout_s)
    return all(pub.wait_for_all_acked(deadline) for pub in node.publishers)
