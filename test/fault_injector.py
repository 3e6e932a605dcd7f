"""Publishes garbage on every input topic of the graph, beside the real publishers (a test tool).

Per topic, in turn: NaN, inf, absurdly large values, no stamp, a stamp older than the newest (out of
order), and stamps ahead of the graph's clock: +1 s, +1000 s, and wall time on a sim-time graph (a
driver with an unsynchronised clock, `ros2 topic pub ... '{header: auto}'`). The unstamped, out-of-order
and future messages carry plausible but wrong values (a 0.2 rad pitch, a 0.8 N·m torque, a target behind
the robot), so a node that accepted one would visibly change the run.
It stamps with the graph's clock (use_sim_time), so NaN/absurd messages are refused for their values,
not for their age. On SIGINT it prints how many messages of each kind it sent, as JSON.

    python test/fault_injector.py --ros-args -p use_sim_time:=true
"""

from __future__ import annotations

import json
import math
import signal
import sys
import time
from collections import Counter
from collections.abc import Callable

import rclpy
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import Imu

from twbr_common.geometry import quaternion_from_rpy
from twbr_common.ros_io import to_stamp
from twbr_msgs.msg import Obstacle, ObstacleArray, PlannerState, WheelTorques

KINDS = ("nan", "inf", "absurd", "unstamped", "out_of_order", "future_1s", "future_1000s", "wall_time")
VALUE_OF = {"nan": math.nan, "inf": math.inf, "absurd": 1e12}
OUT_OF_ORDER_S = 0.1  # older than the newest real message, yet younger than every timeout (0.1 s and up)
AHEAD_NS = {"future_1s": 10**9, "future_1000s": 1000 * 10**9}


def _odom(bad: float | None) -> Odometry:
    m = Odometry()
    m.header.frame_id, m.child_frame_id = "odom", "base_link"
    m.pose.pose.position.x = bad if bad is not None else -3.0
    q = quaternion_from_rpy(0.0, 0.2, 1.0)
    o = m.pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    m.twist.twist.linear.x = bad if bad is not None else 0.5
    m.twist.twist.angular.z = 0.7
    return m


def _imu(bad: float | None) -> Imu:
    m = Imu()
    m.header.frame_id = "base_link"
    o = m.orientation
    o.x, o.y, o.z, o.w = quaternion_from_rpy(0.0, 0.2, 0.0)
    m.angular_velocity.y = bad if bad is not None else 1.0
    return m


def _torques(bad: float | None) -> WheelTorques:
    m = WheelTorques(left=bad if bad is not None else 0.8, right=0.8)
    m.header.frame_id = "base_link"
    return m


def _target(bad: float | None) -> Odometry:
    m = _odom(None)
    m.pose.pose.position.x = bad if bad is not None else -6.0
    m.pose.pose.position.y = -6.0
    m.twist.twist.linear.x = 0.0
    return m


def _obstacles(bad: float | None) -> ObstacleArray:
    m = ObstacleArray()
    m.header.frame_id = "odom"
    # One big obstacle over the start: accepted, its repulsion would throw the robot off its course.
    m.obstacles.append(Obstacle(id=99, radius=bad if bad is not None else 1.0))
    m.obstacles[0].position.x = 0.5
    return m


def _planner_state(bad: float | None) -> PlannerState:
    m = PlannerState(velocity_cmd=bad if bad is not None else 0.5, mode="tracking")
    m.header.frame_id = "odom"
    return m


STAMPED: dict[str, tuple[type, Callable[[float | None], object]]] = {
    "odom": (Odometry, _odom),
    "imu": (Imu, _imu),
    "wheel_torque_cmd": (WheelTorques, _torques),
    "target": (Odometry, _target),
    "obstacles": (ObstacleArray, _obstacles),
    "planner_state": (PlannerState, _planner_state),
}


class FaultInjector(Node):
    def __init__(self) -> None:
        super().__init__("fault_injector")
        self.declare_parameter("rate", 10.0)  # messages per second per topic [Hz], wall time
        self.declare_parameter("topics", [*STAMPED, "cmd_vel"])
        # flood_obstacles > 0: instead, obstacle arrays of that many obstacles, 500 m away and unstamped (what
        # `ros2 topic pub -r R /obstacles ...` sends), at `rate`: a flood of large messages
        self.declare_parameter("flood_obstacles", 0)
        count = self.get_parameter("flood_obstacles").value
        topics = set(self.get_parameter("topics").value) if count <= 0 else set()
        self.pubs = {topic: self.create_publisher(kind, topic, 10) for topic, (kind, _) in STAMPED.items()
                     if topic in topics}
        self.pub_cmd_vel = self.create_publisher(Twist, "cmd_vel", 10) if "cmd_vel" in topics else None
        self.sent: Counter[str] = Counter()
        self._turn = 0
        if count > 0:
            self.flood = ObstacleArray()
            for i in range(count):
                o = Obstacle(id=1000 + i, radius=0.3)
                o.position.x, o.position.y = 500.0 + (i % 100), 500.0 + i // 100
                self.flood.obstacles.append(o)
            self.pub_flood = self.create_publisher(ObstacleArray, "obstacles", 10)
            self.create_timer(1.0 / self.get_parameter("rate").value, self._flood)
        else:
            self.create_timer(1.0 / self.get_parameter("rate").value, self._tick)

    def _flood(self) -> None:
        self.pub_flood.publish(self.flood)
        self.sent["obstacles:flood"] += 1

    def _tick(self) -> None:
        now = self.get_clock().now().nanoseconds
        if now <= 2 * 10**9:  # before 2 s a zero stamp is a real one (the guards' timeouts are shorter)
            return
        kind = KINDS[self._turn % len(KINDS)]
        self._turn += 1
        for topic, pub in self.pubs.items():
            msg = STAMPED[topic][1](VALUE_OF.get(kind))
            if kind == "unstamped":
                msg.header.stamp = Time()
            elif kind == "wall_time":
                msg.header.stamp = to_stamp(time.time_ns())
            else:
                offset = -round(OUT_OF_ORDER_S * 1e9) if kind == "out_of_order" else AHEAD_NS.get(kind, 0)
                msg.header.stamp = to_stamp(now + offset)
            pub.publish(msg)
            self.sent[f"{topic}:{kind}"] += 1
        if self.pub_cmd_vel is not None and kind in VALUE_OF:  # a Twist has no stamp: only its values can be bad
            twist = Twist()
            twist.linear.x = twist.angular.z = VALUE_OF[kind]
            self.pub_cmd_vel.publish(twist)
            self.sent[f"cmd_vel:{kind}"] += 1


def main() -> int:
    # Its own SIGINT/SIGTERM handling and bounded waits: the test reads the counts it prints on the way out,
    # and once (1 CI run in many) rclpy's handler left rclpy.spin() blocked past the test's 10 s.
    rclpy.init(args=sys.argv, signal_handler_options=SignalHandlerOptions.NO)
    stopping: list[int] = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda received, _frame: stopping.append(received))
    node = FaultInjector()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    while not stopping:
        executor.spin_once(timeout_sec=0.1)
    print(json.dumps(dict(node.sent)), flush=True)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
