"""The perception sensors' messages (the ROS side of lidar.py and target_sensor.py): sensor_msgs/LaserScan,
geometry_msgs/PoseArray of target detections, and each sensor's static transform above base_link."""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray, TransformStamped
from sensor_msgs.msg import LaserScan


def laser_scan(cfg: dict, ranges, stamp: Time) -> LaserScan:
    """A scan as sensor_msgs/LaserScan: stamped at its first beam, REP 117 values kept as they are."""
    msg = LaserScan()
    msg.header.stamp = stamp
    msg.header.frame_id = cfg["lidar.frame"]
    beams = len(ranges)
    msg.angle_min = float(cfg["lidar.angle_min"])
    msg.angle_increment = float(cfg["lidar.angle_increment"])
    msg.angle_max = msg.angle_min + (beams - 1) * msg.angle_increment
    msg.scan_time = 1.0 / cfg["lidar.rate"]
    msg.time_increment = msg.scan_time / beams
    msg.range_min = float(cfg["lidar.range_min"])
    msg.range_max = float(cfg["lidar.range_max"])
    msg.ranges = ranges.astype("float32").tolist()
    return msg


def target_detections(cfg: dict, detection: tuple[float, float] | None, stamp: Time) -> PoseArray:
    """A target detector's look at one instant, as geometry_msgs/PoseArray in its frame: one pose at the
    measured range and bearing (x ahead, y left), or none when it did not see the target. An empty array
    is a measurement too: the sensor looked, and the target was not in view."""
    msg = PoseArray()
    msg.header.stamp = stamp
    msg.header.frame_id = cfg["target_sensor.frame"]
    if detection is not None:
        distance, bearing = detection
        pose = Pose()
        pose.position.x = distance * math.cos(bearing)
        pose.position.y = distance * math.sin(bearing)
        pose.orientation.w = 1.0
        msg.poses = [pose]
    return msg


def sensor_transform(frame: str, height: float, base_frame: str, stamp: Time) -> TransformStamped:
    """base_link -> a sensor `height` [m] up the body's axis (base_link is pitched with the body)."""
    tf = TransformStamped()
    tf.header.stamp = stamp
    tf.header.frame_id = base_frame
    tf.child_frame_id = frame
    tf.transform.translation.z = float(height)
    tf.transform.rotation.w = 1.0
    return tf


def laser_transform(cfg: dict, base_frame: str, stamp: Time) -> TransformStamped:
    """base_link -> the scanner: lidar.height up the body's axis."""
    return sensor_transform(cfg["lidar.frame"], cfg["lidar.height"], base_frame, stamp)


def target_sensor_transform(cfg: dict, base_frame: str, stamp: Time) -> TransformStamped:
    """base_link -> the target detector: target_sensor.height up the body's axis."""
    return sensor_transform(cfg["target_sensor.frame"], cfg["target_sensor.height"], base_frame, stamp)
