"""RViz/Foxglove markers: the few shapes the world and the planner draw, built one way."""

from __future__ import annotations

from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker

Color = tuple[float, float, float, float]


def marker(stamp: Time, frame: str, namespace: str, mid: int, kind: int, color: Color) -> Marker:
    """A marker that disappears 2 s after its last update (a node that stops leaves no stale drawing)."""
    m = Marker()
    m.header.stamp = stamp
    m.header.frame_id = frame
    m.ns = namespace
    m.id = mid
    m.type = kind
    m.action = Marker.ADD
    m.pose.orientation.w = 1.0
    m.color = ColorRGBA(r=color[0], g=color[1], b=color[2], a=color[3])
    m.lifetime = Duration(sec=2)
    return m


def arrow(stamp: Time, frame: str, namespace: str, mid: int, start: tuple[float, float, float],
          end: tuple[float, float, float], color: Color) -> Marker:
    m = marker(stamp, frame, namespace, mid, Marker.ARROW, color)
    m.points = [Point(x=start[0], y=start[1], z=start[2]), Point(x=end[0], y=end[1], z=end[2])]
    m.scale.x, m.scale.y, m.scale.z = 0.05, 0.12, 0.15
    return m
