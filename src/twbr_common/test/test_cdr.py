import struct
from pathlib import Path

import numpy as np
import pytest
from ament_index_python.packages import get_package_share_directory
from builtin_interfaces.msg import Time
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from sensor_msgs.msg import Imu

from twbr_common import cdr
from twbr_common.cdr import (
    header_stamp_seconds,
    imu_fields,
    imu_fields_of,
    obstacle_rows,
    obstacle_rows_of,
    odom_pose,
    odom_pose_of,
    odom_twist,
    odom_twist_of,
)
from twbr_common.ros_io import stamp_seconds
from twbr_msgs.msg import Obstacle, ObstacleArray

# frame_id lengths from empty to past a double's alignment, so every padding case is read
FRAMES = ["", "o", "odom", "odom_frame", "a_much_longer_frame_name_x"]


@pytest.mark.parametrize("kind", [Odometry, Imu])
@pytest.mark.parametrize(("sec", "nanosec"), [(0, 0), (12, 345_678_901), (2**31 - 1, 999_999_999), (-3, 5)])
def test_the_stamp_read_from_the_bytes_is_the_deserialized_one(kind, sec, nanosec):
    msg = kind()
    msg.header.stamp = Time(sec=sec, nanosec=nanosec)
    msg.header.frame_id = "odom"
    assert header_stamp_seconds(serialize_message(msg)) == stamp_seconds(msg.header.stamp)


def test_big_endian_cdr_is_read_and_other_encodings_are_left_to_the_deserializer():
    big = b"\x00\x00\x00\x00" + struct.pack(">iI", 7, 250_000_000) + b"\x00" * 8
    assert header_stamp_seconds(big) == 7.25
    for encapsulation in (b"\x00\x03", b"\x00\x07", b"\x01\x01"):  # parameter list, XCDR2, unknown
        assert header_stamp_seconds(encapsulation + big[2:]) is None
    assert header_stamp_seconds(b"\x00\x01\x00\x00\x07") is None  # too short to hold a stamp


def odometry(frame: str, child: str, k: float) -> Odometry:
    msg = Odometry()
    msg.header.stamp = Time(sec=41, nanosec=5_000_000)
    msg.header.frame_id, msg.child_frame_id = frame, child
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = 1.5 * k, -2.25, 0.1
    o.x, o.y, o.z, o.w = 0.0, 0.1 * k, 0.2, 0.97
    msg.pose.covariance[0] = msg.pose.covariance[35] = 7.0  # neighbours of what is read must not leak in
    t = msg.twist.twist
    t.linear.x, t.linear.y, t.linear.z = 0.3 * k, 11.0, 12.0
    t.angular.x, t.angular.y, t.angular.z = 13.0, -0.4, -0.05 * k
    msg.twist.covariance[0] = 99.0
    return msg


def imu(frame: str, k: float, raw: bool) -> Imu:
    msg = Imu()
    msg.header.stamp = Time(sec=3, nanosec=995_000_000)
    msg.header.frame_id = frame
    o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
    o.x, o.y, o.z, o.w = 0.01 * k, 0.02, 0.03, 0.99
    msg.orientation_covariance[0] = -1.0 if raw else 1e-4
    msg.orientation_covariance[8] = 5.0
    w.x, w.y, w.z = 0.1, -0.2 * k, 0.3
    msg.angular_velocity_covariance[8] = 6.0
    a.x, a.y, a.z = 0.5 * k, -0.6, 9.81
    msg.linear_acceleration_covariance[0] = 8.0
    return msg


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("child", FRAMES)
def test_odom_twist_read_from_the_bytes_is_the_deserialized_one(frame, child):
    msg = odometry(frame, child, 1.7)
    data = serialize_message(msg)
    assert cdr._plain_odom_twist(data) is not None  # the fast path, not the fallback
    assert odom_twist(data) == odom_twist_of(msg)


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("child", FRAMES)
def test_odom_pose_read_from_the_bytes_is_the_deserialized_one(frame, child):
    msg = odometry(frame, child, -1.3)
    data = serialize_message(msg)
    assert cdr._plain_odom_pose(data) is not None
    pose = odom_pose(data)
    assert pose == odom_pose_of(msg)
    assert (pose.frame_id, pose.child_frame_id, pose.x, pose.velocity) == (frame, child, 1.5 * -1.3, 0.3 * -1.3)
    assert pose.x_variance == 7.0 and pose.known
    msg.pose.covariance[0] = cdr.UNKNOWN_POSITION  # a tracker that has not seen its target yet
    assert not odom_pose(serialize_message(msg)).known and not odom_pose_of(msg).known


def test_a_frame_name_beyond_ascii_is_read_in_place_and_one_not_utf8_is_left_to_the_deserializer():
    msg = odometry("carte_été", "base_link", 1.0)
    assert cdr._plain_odom_pose(serialize_message(msg)) == odom_pose_of(msg)
    data = bytearray(serialize_message(odometry("odom", "base_link", 1.0)))
    data[16] = 0xFF  # frame_id's first byte
    assert cdr._plain_odom_pose(bytes(data)) is None
    assert odom_pose(bytes(data)).frame_id[1:] == "dom"  # rclpy's reading: the bad byte replaced


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("raw", [False, True])
def test_imu_fields_read_from_the_bytes_are_the_deserialized_ones(frame, raw):
    msg = imu(frame, -0.8, raw)
    data = serialize_message(msg)
    assert cdr._plain_imu_fields(data) is not None
    fields = imu_fields(data)
    assert fields == imu_fields_of(msg)
    assert fields.no_orientation is raw


def big_endian(msg, typename: str) -> bytes:
    """The message as a big-endian CDR writer (another vendor, another machine) would send it."""
    store = get_typestore(Stores.ROS2_JAZZY)
    if typename.startswith("twbr_msgs/"):
        share = Path(get_package_share_directory("twbr_msgs")) / "msg"
        for name in ("Obstacle", "ObstacleArray"):
            store.register(get_types_from_msg((share / f"{name}.msg").read_text(), f"twbr_msgs/msg/{name}"))
    little = serialize_message(msg)
    decoded = store.deserialize_cdr(little, typename)
    big = bytes(store.serialize_cdr(decoded, typename, little_endian=False))
    assert big[:2] == b"\x00\x00"
    return big


@pytest.mark.parametrize("frame", ["", "odom_frame"])
def test_big_endian_messages_are_read_in_place_too(frame):
    odom = odometry(frame, "base_link", 0.9)
    data = big_endian(odom, "nav_msgs/msg/Odometry")
    assert cdr._plain_odom_twist(data) == odom_twist_of(odom)
    assert cdr._plain_odom_pose(data) == odom_pose_of(odom)
    reading = imu(frame, 1.1, False)
    assert cdr._plain_imu_fields(big_endian(reading, "sensor_msgs/msg/Imu")) == imu_fields_of(reading)


def test_bytes_the_fast_path_declines_are_deserialized(monkeypatch):
    msg = odometry("odom", "base_link", 2.0)
    reading = imu("base_link", 2.0, True)
    monkeypatch.setattr(cdr, "_plain_odom_twist", lambda data: None)
    monkeypatch.setattr(cdr, "_plain_odom_pose", lambda data: None)
    monkeypatch.setattr(cdr, "_plain_imu_fields", lambda data: None)
    assert odom_twist(serialize_message(msg)) == odom_twist_of(msg)
    assert odom_pose(serialize_message(msg)) == odom_pose_of(msg)
    assert imu_fields(serialize_message(reading)) == imu_fields_of(reading)


@pytest.mark.parametrize("cut", [3, 8, 16, 40, 200, 300])
def test_truncated_bytes_are_none_never_a_misreading(cut):
    odom, reading = serialize_message(odometry("odom", "base_link", 1.0)), serialize_message(imu("imu", 1.0, False))
    assert cut < min(len(odom), len(reading))
    assert odom_twist(odom[:cut]) is None
    assert odom_pose(odom[:cut]) is None
    assert imu_fields(reading[:cut]) is None


def test_a_string_length_past_the_end_is_declined_by_both_paths():
    odom = serialize_message(odometry("odom", "base_link", 1.0))
    lying = odom[:12] + struct.pack("<I", 10**6) + odom[16:]  # frame_id's length
    assert cdr._plain_odom_twist(lying) is None
    assert odom_twist(lying) is None
    assert cdr._plain_odom_pose(lying) is None
    assert odom_pose(lying) is None


def test_another_encapsulation_is_left_to_the_deserializer():
    msg = odometry("odom", "base_link", 1.0)
    pl_cdr = b"\x00\x03" + serialize_message(msg)[2:]  # PL_CDR little endian: Fast CDR reads it
    assert cdr._plain_odom_twist(pl_cdr) is None
    assert odom_twist(pl_cdr) == odom_twist_of(msg)
    assert cdr._plain_odom_pose(pl_cdr) is None
    assert odom_pose(pl_cdr) == odom_pose_of(msg)


def obstacle_array(frame: str, count: int) -> ObstacleArray:
    msg = ObstacleArray()
    msg.header.stamp = Time(sec=9, nanosec=50_000_000)
    msg.header.frame_id = frame
    for i in range(count):
        o = Obstacle(id=7 * i + 1, radius=0.25 + 0.1 * i)
        o.position.x, o.position.y, o.position.z = 1.0 + i, -2.0 * i, 0.5  # z: not read
        o.velocity.x, o.velocity.y, o.velocity.z = 0.1 * i, -0.3, 4.0
        msg.obstacles.append(o)
    return msg


def assert_same_rows(read, msg: ObstacleArray) -> None:
    expected = obstacle_rows_of(msg)
    assert read.stamp == expected.stamp == msg.header.stamp
    assert read.rows.shape == (len(msg.obstacles), 6)
    np.testing.assert_array_equal(read.rows, expected.rows)


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("count", [0, 1, 2, 5, 5000])
def test_obstacle_rows_read_from_the_bytes_are_the_deserialized_ones(frame, count):
    msg = obstacle_array(frame, count)
    data = serialize_message(msg)
    assert cdr._plain_obstacle_rows(data) is not None
    read = obstacle_rows(data)
    assert_same_rows(read, msg)
    if count:
        assert tuple(read.rows[-1]) == (7 * count - 6, count, -2.0 * (count - 1), 0.1 * (count - 1), -0.3,
                                        0.25 + 0.1 * (count - 1))
    assert_same_rows(cdr._plain_obstacle_rows(big_endian(msg, "twbr_msgs/msg/ObstacleArray")), msg)


def test_obstacle_bytes_declined_in_place_are_deserialized_and_bad_ones_are_none(monkeypatch):
    data = serialize_message(obstacle_array("map", 3))
    for cut in (3, 20, 40, len(data) - 1):
        assert obstacle_rows(data[:cut]) is None
    count_at = cdr._align(cdr._HEADER + 8 + 4 + len("map") + 1, 4)
    lying = data[:count_at] + struct.pack("<I", 10**6) + data[count_at + 4:]  # the sequence's length
    assert cdr._plain_obstacle_rows(lying) is None
    assert obstacle_rows(lying) is None
    monkeypatch.setattr(cdr, "_plain_obstacle_rows", lambda data: None)
    assert_same_rows(obstacle_rows(data), obstacle_array("map", 3))
