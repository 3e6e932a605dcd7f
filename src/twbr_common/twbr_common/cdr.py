"""The few fields a node acts on, read in place from a serialized message (plain CDR, XCDR1).

Deserializing a nav_msgs/Odometry into Python builds ten message objects and two 36-element covariance
arrays: 34 µs, against 3 µs to read its stamp and twist from the bytes (sensor_msgs/Imu: 16 µs). At 200 Hz
on every state of a lockstep graph that sits between a state and its command. Anything these readers do
not recognise (another encapsulation such as XCDR2, bytes too short for their own length fields) they
deserialize as before, so a message is never misread, only read the slow way; bytes that are no such
message at all give None.

Offsets follow classic CDR: the 4-byte encapsulation header (0x0000 big, 0x0001 little endian), then the
fields, each aligned to its own size counted from the end of that header; a string is a uint32 length
(its terminating NUL included) and its bytes.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any, NamedTuple, TypeVar

import numpy as np
from builtin_interfaces.msg import Time
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Imu

from twbr_msgs.msg import ObstacleArray

T = TypeVar("T")
_HEADER = 4  # encapsulation id and options
_STRUCTS: dict[tuple[str, str], struct.Struct] = {}


def _unpack(order: str, fmt: str, data: bytes, offset: int) -> tuple:
    s = _STRUCTS.get((order, fmt))
    if s is None:
        s = _STRUCTS[(order, fmt)] = struct.Struct(order + fmt)
    return s.unpack_from(data, offset)


def _byte_order(data: bytes) -> str | None:
    if len(data) < _HEADER + 8 or data[0] != 0 or data[1] not in (0, 1):
        return None
    return "<" if data[1] == 1 else ">"


def _align(offset: int, size: int) -> int:
    """`offset` (from the start of the data) moved up to a multiple of `size` counted past the header."""
    return _HEADER + (offset - _HEADER + size - 1) // size * size


def _past_string(data: bytes, order: str, offset: int) -> int | None:
    """The offset just past the string whose length field is at (or aligned up from) `offset`."""
    offset = _align(offset, 4)
    if offset + 4 > len(data):
        return None
    (length,) = _unpack(order, "I", data, offset)
    end = offset + 4 + length
    return end if end <= len(data) else None


def _string_at(data: bytes, order: str, offset: int) -> tuple[str, int] | None:
    """The string whose length field is at (or aligned up from) `offset`, and the offset past it; None
    unless it ends in its NUL and is UTF-8 (the deserializer then decides)."""
    start = _align(offset, 4)
    end = _past_string(data, order, start)
    if end is None or end - start < 5 or data[end - 1] != 0:
        return None
    try:
        return data[start + 4:end - 1].decode(), end
    except UnicodeDecodeError:
        return None


def _stamp(data: bytes) -> tuple[str, int, int] | None:
    """Byte order, and the sec and nanosec of the std_msgs/Header the message starts with."""
    order = _byte_order(data)
    if order is None:
        return None
    return order, *_unpack(order, "iI", data, _HEADER)


def header_stamp_seconds(data: bytes) -> float | None:
    """The header stamp [s] of a serialized message whose first field is a std_msgs/Header; None unless
    plain CDR."""
    stamp = _stamp(data)
    return None if stamp is None else stamp[1] + stamp[2] * 1e-9


def _header(data: bytes) -> tuple[str, Time, int] | None:
    """Byte order, stamp, and the offset past frame_id."""
    stamp = _stamp(data)
    if stamp is None:
        return None
    order, sec, nanosec = stamp
    end = _past_string(data, order, _HEADER + 8)
    if end is None:
        return None
    return order, Time(sec=sec, nanosec=nanosec), end


class OdomTwist(NamedTuple):
    """What the controller takes from odom: the stamp, forward speed [m/s] and yaw rate [rad/s], and the pose
    (x, y [m], orientation x, y, z, w) its collision monitor places the robot with."""

    stamp: Time
    velocity: float
    yaw_rate: float
    x: float = 0.0
    y: float = 0.0
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)


# Odometry after child_frame_id: pose.pose (position 3, orientation 4 doubles), pose.covariance (36),
# then twist.twist.linear (3) and angular (3), and twist.covariance (36).
_ODOM_TWIST_OFFSET = 8 * (3 + 4 + 36)
_ODOM_BODY = _ODOM_TWIST_OFFSET + 8 * (6 + 36)


def _odom_pose_offset(data: bytes, child_end: int) -> int | None:
    """Where an Odometry's pose starts, after child_frame_id (which ends at `child_end`); None unless the whole
    message is there, as the deserializer insists."""
    pose = _align(child_end, 8)
    return pose if pose + _ODOM_BODY <= len(data) else None


def odom_twist(data: bytes) -> OdomTwist | None:
    """From a serialized nav_msgs/Odometry; None if the bytes are not one."""
    return _read(data, _plain_odom_twist, Odometry, odom_twist_of)


def _plain_odom_twist(data: bytes) -> OdomTwist | None:
    head = _header(data)
    if head is None:
        return None
    order, stamp, offset = head
    child_end = _past_string(data, order, offset)
    pose = None if child_end is None else _odom_pose_offset(data, child_end)
    if pose is None:
        return None
    x, y, _z, qx, qy, qz, qw = _unpack(order, "7d", data, pose)
    vx, _vy, _vz, _wx, _wy, wz = _unpack(order, "6d", data, pose + _ODOM_TWIST_OFFSET)
    return OdomTwist(stamp, vx, wz, x, y, (qx, qy, qz, qw))


def odom_twist_of(msg: Odometry) -> OdomTwist:
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    return OdomTwist(msg.header.stamp, msg.twist.twist.linear.x, msg.twist.twist.angular.z, p.x, p.y,
                     (o.x, o.y, o.z, o.w))


# A pose covariance whose first element is this says "no position known" (the convention of
# sensor_msgs/Imu's orientation_covariance[0] = -1): a tracker that has not seen its target yet.
UNKNOWN_POSITION = -1.0


class OdomPose(NamedTuple):
    """What the planner takes from odom: the stamp, both frames, the position x, y [m], the orientation
    (x, y, z, w), the forward speed [m/s] and the position's x variance [m²] (UNKNOWN_POSITION: none)."""

    stamp: Time
    frame_id: str
    child_frame_id: str
    x: float
    y: float
    orientation: tuple[float, float, float, float]
    velocity: float
    x_variance: float = 0.0

    @property
    def known(self) -> bool:
        return self.x_variance != UNKNOWN_POSITION


def odom_pose(data: bytes) -> OdomPose | None:
    """From a serialized nav_msgs/Odometry; None if the bytes are not one."""
    return _read(data, _plain_odom_pose, Odometry, odom_pose_of)


def _plain_odom_pose(data: bytes) -> OdomPose | None:
    stamp = _stamp(data)
    if stamp is None:
        return None
    order, sec, nanosec = stamp
    frame = _string_at(data, order, _HEADER + 8)
    child = None if frame is None else _string_at(data, order, frame[1])
    pose = None if child is None else _odom_pose_offset(data, child[1])
    if pose is None:
        return None
    x, y, _z, qx, qy, qz, qw, x_variance = _unpack(order, "8d", data, pose)
    (velocity,) = _unpack(order, "d", data, pose + _ODOM_TWIST_OFFSET)
    return OdomPose(Time(sec=sec, nanosec=nanosec), frame[0], child[0], x, y, (qx, qy, qz, qw), velocity,
                    x_variance)


def odom_pose_of(msg: Odometry) -> OdomPose:
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    return OdomPose(msg.header.stamp, msg.header.frame_id, msg.child_frame_id, p.x, p.y, (o.x, o.y, o.z, o.w),
                    msg.twist.twist.linear.x, msg.pose.covariance[0])


class ObstacleRows(NamedTuple):
    """A twbr_msgs/ObstacleArray's stamp and one row per obstacle: id, x, y, vx, vy, radius (m, m/s)."""

    stamp: Time
    rows: np.ndarray


# An Obstacle: uint32 id, then (aligned to 8) position (3 doubles), velocity (3), radius.
_OBSTACLE_DOUBLES = 7
_OBSTACLE_MIN_SIZE = 4 + 8 * _OBSTACLE_DOUBLES


def obstacle_rows(data: bytes) -> ObstacleRows | None:
    """From a serialized twbr_msgs/ObstacleArray; None if the bytes are not one."""
    return _read(data, _plain_obstacle_rows, ObstacleArray, obstacle_rows_of)


def _plain_obstacle_rows(data: bytes) -> ObstacleRows | None:
    head = _header(data)
    if head is None:
        return None
    order, stamp, offset = head
    offset = _align(offset, 4)
    if offset + 4 > len(data):
        return None
    (count,) = _unpack(order, "I", data, offset)
    offset += 4
    if count * _OBSTACLE_MIN_SIZE > len(data) - offset:  # a length field no message of these bytes can have
        return None
    rows = np.empty((count, 6))
    if count:
        # Each Obstacle is a uint32 id, padding to 8, then 7 doubles (position, velocity, radius): from the
        # second one on the records repeat every 64 bytes, so the whole array is read as one strided view
        # (a 5,000-obstacle message: ~0.1 ms, where a loop over the records took ~8 ms).
        first = _align(offset + 4, 8)
        stride = 8 + 8 * _OBSTACLE_DOUBLES
        if first + stride * (count - 1) + 8 * _OBSTACLE_DOUBLES > len(data):
            return None
        doubles = np.ndarray((count, _OBSTACLE_DOUBLES), dtype=np.dtype(order + "f8"), buffer=data, offset=first,
                             strides=(stride, 8))
        ids = np.ndarray((count - 1,), dtype=np.dtype(order + "u4"), buffer=data, offset=first + stride - 8,
                         strides=(stride,))
        rows[0, 0] = _unpack(order, "I", data, offset)[0]
        rows[1:, 0] = ids
        rows[:, 1:3] = doubles[:, 0:2]  # position x, y
        rows[:, 3:5] = doubles[:, 3:5]  # velocity x, y
        rows[:, 5] = doubles[:, 6]  # radius
    return ObstacleRows(stamp, rows)


def obstacle_rows_of(msg: ObstacleArray) -> ObstacleRows:
    rows = [(o.id, o.position.x, o.position.y, o.velocity.x, o.velocity.y, o.radius) for o in msg.obstacles]
    return ObstacleRows(msg.header.stamp, np.array(rows, dtype=float).reshape(len(rows), 6))


class ImuFields(NamedTuple):
    """An imu message's stamp, orientation (x, y, z, w), whether it has none (REP 145:
    orientation_covariance[0] == -1), angular velocity [rad/s] and linear acceleration [m/s^2]."""

    stamp: Time
    orientation: tuple[float, float, float, float]
    no_orientation: bool
    angular_velocity: tuple[float, float, float]
    linear_acceleration: tuple[float, float, float]


# Imu after the header: orientation (4 doubles), its covariance (9), angular_velocity (3), its covariance
# (9), linear_acceleration (3), its covariance (9).
_IMU_DOUBLES = 4 + 9 + 3 + 9 + 3
_IMU_END = 8 * (_IMU_DOUBLES + 9)


def imu_fields(data: bytes) -> ImuFields | None:
    """From a serialized sensor_msgs/Imu; None if the bytes are not one."""
    return _read(data, _plain_imu_fields, Imu, imu_fields_of)


def _plain_imu_fields(data: bytes) -> ImuFields | None:
    head = _header(data)
    if head is None:
        return None
    order, stamp, offset = head
    start = _align(offset, 8)
    if start + _IMU_END > len(data):  # the whole message, as the deserializer would insist
        return None
    v = _unpack(order, f"{_IMU_DOUBLES}d", data, start)
    return ImuFields(stamp, v[0:4], v[4] == -1.0, v[13:16], v[25:28])


def imu_fields_of(msg: Imu) -> ImuFields:
    o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
    return ImuFields(msg.header.stamp, (o.x, o.y, o.z, o.w), msg.orientation_covariance[0] == -1.0,
                     (w.x, w.y, w.z), (a.x, a.y, a.z))


def _read(data: bytes, plain: Callable[[bytes], T | None], message_type: type, of: Callable[[Any], T]) -> T | None:
    """The fields from the bytes in place, or else from the deserialized message."""
    fields = plain(data)
    if fields is None:
        msg = deserialize_or_none(data, message_type)
        fields = None if msg is None else of(msg)
    return fields


def deserialize_or_none(data: bytes, message_type: type):
    """The message, or None when the bytes are not one (a raw subscription's data is not checked by the
    middleware: a malformed sample from a neighbour must not raise in a callback)."""
    try:
        return deserialize_message(data, message_type)
    except RuntimeError:  # rclpy's RMWError: "failed to deserialize ROS message"
        return None
