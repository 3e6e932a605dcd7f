"""tracker_node: obstacles from a 2D LiDAR, for the planner (issue 36).

Subscribes `scan` (sensor_msgs/LaserScan) and `odom` (the robot's pose and pitch); publishes `obstacles`
(twbr_msgs/ObstacleArray in the odom frame, stamped with the scan's stamp): the confirmed tracks with their
velocities and a wall's chain of discs. A scan is placed with the first odom stamped at or after its stamp
(a simulator sends the scan of an instant before its odom; a robot's odom comes at 100-200 Hz), waiting for
it if need be, so the tracks are the same however the two streams interleave: a lockstep run is the same
loaded or idle. A scan with no such odom within `odom_timeout` of it is dropped (and said so), never placed
at a stale pose; a scan not newer than the last one (a simulator offering its first state again) is skipped.

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
    ParamSpec("odom_timeout", 0.2, "a scan whose first odom at or after it comes later than this is dropped", "s",
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
        self._pose: tuple[float, ...] | None = None  # newest odom: stamp, x, y, yaw, speed, yaw rate, pitch
        self._waiting: LaserScan | None = None  # a scan newer than every odom yet: placed by the next one
        self._last_scan = -math.inf  # stamp of the last scan tracked
        self.latencies = LatencyRecord()  # scan and its odom in -> obstacles published, in constant memory
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
        self._waiting = None
        self._last_scan = -math.inf

    def _on_odom(self, msg: Odometry) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        stamp = stamp_seconds(msg.header.stamp)
        v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
        if not self.inputs.admit("odom", stamp, (p.x, p.y, o.x, o.y, o.z, o.w, v, w), self._now()):
            return
        _roll, pitch, yaw = rpy_from_quaternion(o.x, o.y, o.z, o.w)
        self._pose = (stamp, p.x, p.y, yaw, v, w, pitch)
        if self._waiting is not None and stamp >= stamp_seconds(self._waiting.header.stamp):
            scan, self._waiting = self._waiting, None
            self._track(scan)

    def _on_scan(self, msg: LaserScan) -> None:
        t = stamp_seconds(msg.header.stamp)
        if t <= self._last_scan:
            return
        if self._waiting is not None and stamp_seconds(self._waiting.header.stamp) != t:  # not an offer again
            self.get_logger().warning(f"scan at t = {stamp_seconds(self._waiting.header.stamp):.3f} s dropped: no"
                                      " odom at or after it before the next scan", throttle_duration_sec=2.0)
        if self._pose is not None and self._pose[0] >= t:
            self._waiting = None
            self._track(msg)
        else:
            self._waiting = msg

    def _track(self, msg: LaserScan) -> None:
        received = time.perf_counter()
        t = stamp_seconds(msg.header.stamp)
        stamp, x, y, yaw, v, w, pitch = self._pose
        if stamp - t > self.cfg["odom_timeout"]:
            self.get_logger().warning(f"scan at t = {t:.3f} s dropped: no odom within {self.cfg['odom_timeout']:g} s"
                                      " of it", throttle_duration_sec=2.0)
            return
        self._last_scan = t
        # the pose carried back to the scan's first beam along the odom's twist
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
