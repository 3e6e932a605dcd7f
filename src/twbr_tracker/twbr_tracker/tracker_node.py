"""tracker_node: obstacles from a 2D LiDAR and the target from a target detector, for the planner (issue 36).

Subscribes `scan` (sensor_msgs/LaserScan), `target_detections` (geometry_msgs/PoseArray in the detector's
frame: one pose where it sees the target, none where it looked and did not) and `odom` (the robot's pose
and pitch); publishes `obstacles` (twbr_msgs/ObstacleArray in odom, stamped with the scan's stamp: the
confirmed tracks with their velocities and a wall's chain of discs; the same as cylinders and arrows on
`tracker_markers` for RViz) and `target` (nav_msgs/Odometry in
odom, stamped with each look: the fused target, its prediction while it is hidden, with the position's
variance in the pose covariance; before the first sighting the prior (target.prior_*) or, without one, a
target whose covariance[0] is -1, position unknown, on which the planner stands).

Each scan and each look is placed with the first odom stamped at or after its stamp (a simulator sends an
instant's scan and look before its odom; a robot's odom comes at 100-200 Hz), waiting for it if need be,
and found among the last `odom_history` seconds of odoms if later ones came first, so the output is the
same however the streams interleave: a lockstep run is the same loaded or idle. One with no such odom
within `odom_timeout` of it, or older than the history, is dropped (and said so), never placed at another
instant's pose; one not newer than the last of its stream (a simulator offering its first state again) is
skipped.

    ros2 run twbr_tracker tracker_node --ros-args --params-file config/tracker.yaml
"""

from __future__ import annotations

import math
import time

import numpy as np
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from twbr_common.cdr import UNKNOWN_POSITION
from twbr_common.geometry import rpy_from_quaternion
from twbr_common.guard import POSITION_LIMIT, SLOW_SIM_FUTURE_TOLERANCE, input_specs
from twbr_common.params import ParamSpec
from twbr_common.ros_io import MARKER_QOS, SENSOR_SUB_QOS, WORLD_PUB_QOS, stamp_seconds
from twbr_common.ros_params import declare, input_streams, run_node
from twbr_common.wire import heading_speed, range_bearing
from twbr_msgs.msg import ObstacleArray
from twbr_sim.run_report import LatencyRecord
from twbr_sim.world import TargetState
from twbr_sim.world_messages import obstacles_message, target_message, world_markers
from twbr_tracker.pose_history import POSE_HISTORY_SPECS, PoseHistory
from twbr_tracker.target import TARGET_SPECS, TargetEstimate, TargetFilter
from twbr_tracker.tracker import TRACKER_SPECS, Tracker

NODE_SPECS: tuple[ParamSpec, ...] = (
    *TRACKER_SPECS,
    *TARGET_SPECS,
    *POSE_HISTORY_SPECS,
    ParamSpec("odom_timeout", 0.2, "a scan or look whose first odom at or after it comes later than this is dropped", "s",
              0.001, 10.0),
    ParamSpec("odom_frame", "odom", "frame of the published obstacles"),
)
# It works outside the lockstep, for milliseconds a scan: its odom may come a few states before its /clock.
INPUT_SPECS = input_specs(SLOW_SIM_FUTURE_TOLERANCE)


class TrackerNode(Node):
    def __init__(self) -> None:
        super().__init__("tracker_node")
        cfg = declare(self, NODE_SPECS)
        self.cfg = cfg
        self.core = Tracker(cfg)
        self.core.warm_up()  # before any publisher: once peers see this node, it answers on time
        self.target = TargetFilter(cfg)
        self.inputs = input_streams(self, SLOW_SIM_FUTURE_TOLERANCE)  # its INPUT_SPECS
        self.inputs.add("odom", cfg["odom_timeout"], limit=POSITION_LIMIT)
        self.inputs.on_restart(self._restart)
        self.poses = PoseHistory(cfg["odom_history"])  # odoms: stamp, x, y, yaw, speed, yaw rate, pitch
        # per stream: a message newer than every odom yet (placed by the next one), and the last one's stamp
        self._waiting: dict[str, LaserScan | PoseArray] = {}
        self._last: dict[str, float] = {}
        self.latencies = LatencyRecord()  # scan and its odom in -> obstacles published, in constant memory
        self.pub_obstacles = self.create_publisher(ObstacleArray, "obstacles", WORLD_PUB_QOS)
        self.pub_target = self.create_publisher(Odometry, "target", WORLD_PUB_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, "tracker_markers", MARKER_QOS)
        self._handlers = {"scan": self._track, "target_detections": self._follow}
        self.create_subscription(Odometry, "odom", self._on_odom, SENSOR_SUB_QOS)
        self.create_subscription(LaserScan, "scan", lambda m: self._on_input("scan", m), SENSOR_SUB_QOS)
        self.create_subscription(PoseArray, "target_detections", lambda m: self._on_input("target_detections", m),
                                 SENSOR_SUB_QOS)
        self.get_logger().info(
            f"tracking scan -> obstacles and target_detections -> target in {cfg['odom_frame']}: gate"
            f" {cfg['tracking.gate']:g} m, confirmed after {cfg['tracking.confirm_hits']} scans, dropped after"
            f" {cfg['tracking.max_misses']} misses or {cfg['tracking.max_coast']:g} s hidden"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _restart(self) -> None:
        self.get_logger().warning("clock jumped back: every track and the target are dropped")
        self.core.reset()
        self.target.reset()
        self.poses.clear()
        self._waiting.clear()
        self._last.clear()

    def _on_odom(self, msg: Odometry) -> None:
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        stamp = stamp_seconds(msg.header.stamp)
        v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
        if not self.inputs.admit("odom", stamp, (p.x, p.y, o.x, o.y, o.z, o.w, v, w), self._now()):
            return
        _roll, pitch, yaw = rpy_from_quaternion(o.x, o.y, o.z, o.w)
        self.poses.add(stamp, p.x, p.y, yaw, v, w, pitch)
        for stream, waiting in list(self._waiting.items()):
            if stamp >= stamp_seconds(waiting.header.stamp):
                del self._waiting[stream]
                self._place(stream, waiting)

    def _on_input(self, stream: str, msg: LaserScan | PoseArray) -> None:
        t = stamp_seconds(msg.header.stamp)
        if t <= self._last.get(stream, -math.inf):
            return
        waiting = self._waiting.pop(stream, None)
        if waiting is not None and stamp_seconds(waiting.header.stamp) != t:  # not the same offered again
            self.get_logger().warning(f"{stream} at t = {stamp_seconds(waiting.header.stamp):.3f} s dropped: no"
                                      " odom at or after it before the next one", throttle_duration_sec=2.0)
        if self.poses.newest() >= t:
            self._place(stream, msg)
        else:
            self._waiting[stream] = msg

    def _place(self, stream: str, msg: LaserScan | PoseArray) -> None:
        """`msg` with the robot's pose at its stamp (the odom's, carried back along its twist)."""
        t = stamp_seconds(msg.header.stamp)
        odom = self.poses.at_or_after(t)
        if odom is None:
            self.get_logger().warning(f"{stream} at t = {t:.3f} s dropped: older than the odom history"
                                      f" ({self.cfg['odom_history']:g} s)", throttle_duration_sec=2.0)
            return
        stamp, x, y, yaw, v, w, pitch = odom
        if stamp - t > self.cfg["odom_timeout"]:
            self.get_logger().warning(f"{stream} at t = {t:.3f} s dropped: no odom within"
                                      f" {self.cfg['odom_timeout']:g} s of it", throttle_duration_sec=2.0)
            return
        self._last[stream] = t
        dt = t - stamp
        pose = (x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw + w * dt, v, w, pitch)
        self._handlers[stream](msg, t, pose)

    def _track(self, msg: LaserScan, t: float, pose: tuple[float, ...]) -> None:
        received = time.perf_counter()
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        obstacles = self.core.step(t, ranges, msg.angle_min, msg.angle_increment, msg.time_increment, *pose)
        self.pub_obstacles.publish(obstacles_message(obstacles, msg.header.stamp, self.cfg["odom_frame"]))
        self.latencies.add(time.perf_counter() - received)
        if self.pub_markers.get_subscription_count():  # built only while RViz or a recorder listens
            markers = world_markers(None, obstacles, 0.0, msg.header.stamp, self.cfg["odom_frame"])
            markers.markers.insert(0, Marker(action=Marker.DELETEALL))  # tracks come and go
            self.pub_markers.publish(markers)

    def _follow(self, msg: PoseArray, t: float, pose: tuple[float, ...]) -> None:
        x, y, yaw, _v, _w, pitch = pose
        if msg.poses:  # the detector saw it (the nearest, if it reports more than one)
            p = min((q.position for q in msg.poses), key=lambda q: range_bearing(q.x, q.y)[0])
            if math.isfinite(p.x) and math.isfinite(p.y):
                self.target.measure(t, *range_bearing(p.x, p.y), x, y, yaw, pitch)
        estimate = self.target.estimate(t)
        self.pub_target.publish(target_odometry(estimate, msg.header.stamp, self.cfg["odom_frame"]))

    def destroy_node(self) -> None:
        self.get_logger().info(self.report())
        super().destroy_node()

    def report(self) -> str:
        if not self.latencies.count:
            return "no scan tracked"
        return (f"{self.latencies.count} scans tracked; scan -> obstacles median"
                f" {self.latencies.quantile_ms(0.5):.3f} ms, p99 {self.latencies.quantile_ms(0.99):.3f} ms")


def target_odometry(estimate: TargetEstimate | None, stamp, frame: str) -> Odometry:
    """The fused target as the planner reads a target (heading along its velocity, forward speed), with the
    position's variance on the pose covariance's x and y; None: a target of unknown position."""
    if estimate is None:
        msg = target_message(TargetState(x=0.0, y=0.0, heading=0.0, speed=0.0, yaw_rate=0.0), stamp, frame)
        covariance = [0.0] * 36
        covariance[0] = UNKNOWN_POSITION
        msg.pose.covariance = covariance
        return msg
    heading, speed = heading_speed(estimate.vx, estimate.vy)
    state = TargetState(x=estimate.x, y=estimate.y, heading=heading, speed=speed, yaw_rate=0.0)
    msg = target_message(state, stamp, frame)
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = estimate.position_variance
    msg.pose.covariance = covariance
    return msg


def main(args: list[str] | None = None) -> int:
    return run_node("tracker_node", TrackerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
