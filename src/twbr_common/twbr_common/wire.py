"""What a value becomes on its way through a ROS message: the roundings the node graph applies between
its cores, for the headless loop and the batch engine to apply at the same places.

The graph's nodes run the same compiled cores as the batch engine, but they read the state from
messages: a time from a stamp's sec and nanosec, a pitch or a yaw from a quaternion, a target's velocity
from a heading and a speed, a detection's range and bearing from a point. Each read-back differs from the
value sent in its last bit, and a planner's decision on its threshold turns a last bit into another path
(a LiDAR run of suite/trap_wedge parted from the batch's after 24 s and reached where the batch's did
not). Applied here too, the graph, the headless loop and the batch engine take one path to the last bit.

tracker_node calls range_bearing and heading_speed itself; the stamp and orientation read-backs compile
the readers' own code (geometry's quaternion pair) or repeat one line of it (ros_io.stamp_seconds,
planner_node's target velocity), and test_wire checks each against the node's reading. Ranges and speeds
are sqrt(x^2 + y^2), not hypot: CPython's math.hypot and the compiled one differ in the last bit, and
sqrt is correctly rounded everywhere.
"""

from __future__ import annotations

import math

from twbr_common.geometry import quaternion_from_rpy, rpy_from_quaternion
from twbr_common.jit import inline_kernel

NS_PER_S = 1_000_000_000

_quaternion = inline_kernel(quaternion_from_rpy)
_rpy = inline_kernel(rpy_from_quaternion)


def step_nanoseconds(rate: float) -> int:
    """A step of `rate` [Hz] in whole nanoseconds: a state's stamp is its step count times this."""
    return round(1e9 / rate)


@inline_kernel
def stamp_seconds_of(ns: int) -> float:
    """A stamp of ns nanoseconds as a node reads it: sec + nanosec * 1e-9 (ros_io.stamp_seconds). It is
    not the sim time k * h: the two differ in the last bit for about one step in eight."""
    return float(ns // NS_PER_S) + float(ns % NS_PER_S) * 1e-9


@inline_kernel
def pitch_yaw_read_back(roll: float, pitch: float, yaw: float) -> tuple[float, float]:
    """(pitch, yaw) [rad] as read from the quaternion of (roll, pitch, yaw) [rad] (odom's, imu's)."""
    x, y, z, w = _quaternion(roll, pitch, yaw)
    _roll, pitch_read, yaw_read = _rpy(x, y, z, w)
    return pitch_read, yaw_read


@inline_kernel
def range_bearing(x: float, y: float) -> tuple[float, float]:
    """Range [m] and bearing [rad] of the point (x, y) [m] (x ahead, y left)."""
    return math.sqrt(x * x + y * y), math.atan2(y, x)


@inline_kernel
def detection_read_back(distance: float, bearing: float) -> tuple[float, float]:
    """A detector's (range [m], bearing [rad]) as tracker_node reads it from the pose it is sent as."""
    return range_bearing(distance * math.cos(bearing), distance * math.sin(bearing))


@inline_kernel
def heading_speed(vx: float, vy: float) -> tuple[float, float]:
    """Heading [rad] and speed [m/s] of the velocity (vx, vy) [m/s], as a target's odometry carries it."""
    return math.atan2(vy, vx), math.sqrt(vx * vx + vy * vy)


@inline_kernel
def target_velocity_read_back(heading: float, speed: float) -> tuple[float, float]:
    """(vx, vy) [m/s] as planner_node reads a target sent with heading [rad] (a quaternion) and speed [m/s]."""
    _pitch, heading_read = pitch_yaw_read_back(0.0, 0.0, heading)
    return speed * math.cos(heading_read), speed * math.sin(heading_read)
