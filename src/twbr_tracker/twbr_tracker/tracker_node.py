"""tracker_node: obstacles from a 2D LiDAR, for the planner (issue 36).

Subscribes `scan` (sensor_msgs/LaserScan) and `odom` (the robot's pose and pitch); publishes `obstacles`
(twbr_msgs/ObstacleArray in the odom frame, stamped with the scan's stamp): the confirmed tracks with their
velocities and a wall's chain of discs. A scan is placed with the newest odom stamped within `odom_timeout`
of it; without one it is dropped (and said so), never placed at a stale pose.

    ros2 run twbr_tracker tracker_node --ros-args --params-file config/tracker.yaml
"""

from __future__ import annotations

import math
import time

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import LaserScan

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.guard import POSITION_LIMIT
from twbr_common.params import ParamSpec
from twbr_common.ros_io import SENSOR_SUB_QOS, WORLD_QOS, stamp_seconds
from twbr_common.ros_params import declare, input_streams, run_node
from twbr_msgs.msg import ObstacleArray
from twbr_sim.run_report import LatencyRecord
from twbr_sim.world_messages import obstacles_message
from twbr_tracker.tracker import TRACKER_SPECS, Tracker

NODE_SPECS: tuple[ParamSpec, ...] = (
    *TRACKER_SPECS,
    ParamSpec("odom_timeout", 0.2, "a scan farther than this from the newest odom's stamp is dropped", "s",
              0.001, 10.0),
    ParamSpec("odom_frame", "odom", "frame of the published obstacles"),
)


class TrackerNode(Node):
    def __init__(self) -> None:
        super().__init__("tracker_node")
        cfg = declare(self, NODE_SPECS)
        self.cfg = cfg
        self.core = Tracker(cfg)
        self.core.warm_up()  # before any publisher: once peers see this node, it answers on time
        self.inputs = input_streams(self)
        self.inputs.add("odom", cfg["odom_timeout"], limit=POSITION_LIMIT)
        self.inputs.on_restart(self._restart)
        self._pose: tuple[float, ...] | None = None  # stamp, x, y, yaw, speed, yaw rate, pitch
        self.latencies = LatencyRecord()  # scan received -> obstacles published, in constant memory
        self.pub_obstacles = self.create_publisher(ObstacleArray, "obstacles", WORLD_QOS)
        self.create_subscription(Odometry, "odom", self._on_odom, SENSOR_SUB_QOS)
        self.create_subscription(LaserScan, "scan", self._on_scan, SENSOR_SUB_QOS)
        self.get_logger().info(
            f"tracking scan -> obstacles in {cfg['odom_frame']}: gate {cfg['tracking.gate']:g} m, confirmed after"
            f" {cfg['tracking.confirm_hits']} scans, dropped after {cfg['tracking.max_misses']} misses"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _restart(self) -> None:
        self.get_logger().warning("clock jumped back: every track is dropped")
        self.core.reset()
        self._pose = None

    def _on_odom(self, msg: Odometry) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        stamp = stamp_seconds(msg.header.stamp)
        v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
        if not self.inputs.admit("odom", stamp, (p.x, p.y, o.x, o.y, o.z, o.w, v, w), self._now()):
            return
        _roll, pitch, yaw = rpy_from_quaternion(o.x, o.y, o.z, o.w)
        self._pose = (stamp, p.x, p.y, yaw, v, w, pitch)

    def _on_scan(self, msg: LaserScan) -> None:
        received = time.perf_counter()
        t = stamp_seconds(msg.header.stamp)
        if self._pose is None or abs(t - self._pose[0]) > self.cfg["odom_timeout"]:
            self.get_logger().warning(f"scan at t = {t:.3f} s dropped: no odom within {self.cfg['odom_timeout']:g} s"
                                      " of it", throttle_duration_sec=2.0)
            return
        stamp, x, y, yaw, v, w, pitch = self._pose
        # the pose carried back (or on) to the scan's first beam along the odom's twist
        dt = t - stamp
        x, y, yaw = x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw + w * dt
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        obstacles = self.core.step(t, ranges, msg.angle_min, msg.angle_increment, msg.time_increment, x, y, yaw, v, w,
                                   pitch)
        self.pub_obstacles.publish(obstacles_message(obstacles, msg.header.stamp, self.cfg["odom_frame"]))
        self.latencies.add(time.perf_counter() - received)

    def destroy_node(self) -> None:
        self.get_logger().info(self.report())
        super().destroy_node()

    def report(self) -> str:
        if not self.latencies.count:
            return "no scan tracked"
        return (f"{self.latencies.count} scans tracked; scan -> obstacles median"
                f" {self.latencies.quantile_ms(0.5):.3f} ms, p99 {self.latencies.quantile_ms(0.99):.3f} ms")


def main(args: list[str] | None = None) -> int:
    return run_node("tracker_node", TrackerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
