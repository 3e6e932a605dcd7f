import struct

import pytest
from builtin_interfaces.msg import Time
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Imu

from twbr_common.ros_io import header_stamp_seconds, stamp_seconds


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
