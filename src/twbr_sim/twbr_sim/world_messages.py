"""World state as ROS messages: shared by sim_node (hosting the world) and world_node."""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Vector3
from nav_msgs.msg import Odometry
from visualization_msgs.msg import Marker, MarkerArray

from twbr_common.geometry import quaternion_from_rpy
from twbr_common.markers import Color, arrow, marker
from twbr_msgs.msg import Obstacle, ObstacleArray, WorldStatus
from twbr_sim.scenario import ObstacleSpec
from twbr_sim.world import Assessment, TargetState

TARGET_FRAME = "target"
MARKER_NAMESPACE = "twbr_world"


def target_message(target: TargetState, stamp: Time, frame: str) -> Odometry:
    """The target as odometry: pose in `frame`, twist in the target's own frame (forward speed, yaw rate)."""
    msg = Odometry()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.child_frame_id = TARGET_FRAME
    msg.pose.pose.position.x = target.x
    msg.pose.pose.position.y = target.y
    q = quaternion_from_rpy(0.0, 0.0, target.heading)
    o = msg.pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    msg.twist.twist.linear.x = target.speed
    msg.twist.twist.angular.z = target.yaw_rate
    return msg


def obstacles_message(obstacles: list[ObstacleSpec], stamp: Time, frame: str) -> ObstacleArray:
    msg = ObstacleArray()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.obstacles = [
        Obstacle(id=o.id, position=Point(x=o.x, y=o.y), velocity=Vector3(x=o.vx, y=o.vy), radius=o.radius)
        for o in obstacles
    ]
    return msg


def world_status_message(a: Assessment, collision_count: int, stamp: Time, frame: str) -> WorldStatus:
    msg = WorldStatus()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.collision = a.collision
    msg.collision_obstacle_id = a.collision_obstacle_id
    msg.collision_count = collision_count
    msg.clearance = a.clearance
    msg.target_distance = a.target_distance
    msg.target_reached = a.target_reached
    return msg


def _marker(stamp: Time, frame: str, mid: int, kind: int, color: Color) -> Marker:
    return marker(stamp, frame, MARKER_NAMESPACE, mid, kind, color)


def world_markers(
    target: TargetState | None, obstacles: list[ObstacleSpec], capture_radius: float, stamp: Time, frame: str
) -> MarkerArray:
    """Obstacles as cylinders, the target as a green sphere with its capture disc and heading arrow."""
    out = MarkerArray()
    for o in obstacles:
        m = _marker(stamp, frame, 100 + o.id, Marker.CYLINDER, (0.85, 0.25, 0.2, 0.8))
        m.pose.position.x, m.pose.position.y, m.pose.position.z = o.x, o.y, 0.25
        m.scale.x = m.scale.y = 2.0 * o.radius
        m.scale.z = 0.5
        out.markers.append(m)
        speed = math.hypot(o.vx, o.vy)
        if speed > 0.0:
            out.markers.append(arrow(stamp, frame, MARKER_NAMESPACE, 200 + o.id, (o.x, o.y, 0.5),
                                     (o.x + 3.0 * o.vx, o.y + 3.0 * o.vy, 0.5), (0.85, 0.25, 0.2, 1.0)))
    if target is not None:
        disc = _marker(stamp, frame, 1, Marker.CYLINDER, (0.1, 0.8, 0.2, 0.3))
        disc.pose.position.x, disc.pose.position.y = target.x, target.y
        disc.scale.x = disc.scale.y = 2.0 * capture_radius
        disc.scale.z = 0.02
        out.markers.append(disc)
        star = _marker(stamp, frame, 2, Marker.SPHERE, (0.1, 0.8, 0.2, 1.0))
        star.pose.position.x, star.pose.position.y, star.pose.position.z = target.x, target.y, 0.2
        star.scale.x = star.scale.y = star.scale.z = 0.3
        out.markers.append(star)
        if target.speed > 0.0:
            vx, vy = target.velocity
            out.markers.append(arrow(stamp, frame, MARKER_NAMESPACE, 3, (target.x, target.y, 0.2),
                                     (target.x + 3.0 * vx, target.y + 3.0 * vy, 0.2), (0.1, 0.8, 0.2, 1.0)))
    return out
