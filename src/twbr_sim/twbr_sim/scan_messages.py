"""sensor_msgs/LaserScan and the scanner's static transform from a scan of lidar.py (the ROS side of it)."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import TransformStamped
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


def laser_transform(cfg: dict, base_frame: str, stamp: Time) -> TransformStamped:
    """base_link -> the scanner: lidar.height up the body's axis (base_link is pitched with the body)."""
    tf = TransformStamped()
    tf.header.stamp = stamp
    tf.header.frame_id = base_frame
    tf.child_frame_id = cfg["lidar.frame"]
    tf.transform.translation.z = float(cfg["lidar.height"])
    tf.transform.rotation.w = 1.0
    return tf
