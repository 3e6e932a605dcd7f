"""The read-backs the headless loop and the batch engine apply are the graph's own, to the last bit: a stamp
as sim_node sends it and a node reads it, a quaternion as sim_node and the world fill it and the nodes
read it, a target's odometry as tracker_node sends it and planner_node reads it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twbr_common.geometry import quaternion_from_rpy, rpy_from_quaternion
from twbr_common.ros_io import stamp_seconds, to_stamp
from twbr_common.wire import (
    detection_read_back,
    heading_speed,
    pitch_yaw_read_back,
    range_bearing,
    stamp_seconds_of,
    step_nanoseconds,
    target_velocity_read_back,
)


@pytest.mark.parametrize("rate", [1000.0, 200.0, 333.0, 7.0])
def test_a_stamp_reads_back_as_the_node_reads_it_and_not_as_k_times_h(rate):
    step_ns = step_nanoseconds(rate)
    differ = 0
    for k in range(0, 130_001, 7):
        ns = k * step_ns
        assert stamp_seconds_of(ns) == stamp_seconds(to_stamp(ns)), (rate, k)
        differ += stamp_seconds_of(ns) != k * (1.0 / rate)  # Simulator.time
    if rate == 1000.0:  # why the read-back is needed: k * h is not what the nodes see
        assert differ > 1000


def test_an_orientation_reads_back_as_rpy_from_quaternion_reads_it():
    rng = np.random.default_rng(3)
    changed = 0
    for _ in range(20_000):
        roll, pitch, yaw = float(rng.normal(0.0, 0.01)), float(rng.normal(0.0, 0.2)), float(rng.uniform(-4.0, 4.0))
        _, pitch_read, yaw_read = rpy_from_quaternion(*quaternion_from_rpy(roll, pitch, yaw))
        assert pitch_yaw_read_back(roll, pitch, yaw) == (pitch_read, yaw_read)
        changed += (pitch_read, yaw_read) != (pitch, math.remainder(yaw, 2 * math.pi))
    assert changed > 1000  # the read-back is not the identity


def test_a_target_sent_as_odometry_reads_back_as_planner_node_reads_it():
    """tracker_node sends (heading, speed) from the fused velocity; planner_node reads the heading from the
    quaternion and takes speed * (cos, sin) of it."""
    rng = np.random.default_rng(4)
    for _ in range(20_000):
        vx, vy = (float(v) for v in rng.normal(0.0, 0.5, 2))
        heading, speed = heading_speed(vx, vy)
        assert (heading, speed) == (math.atan2(vy, vx), math.sqrt(vx * vx + vy * vy))
        _, _, heading_read = rpy_from_quaternion(*quaternion_from_rpy(0.0, 0.0, heading))
        assert target_velocity_read_back(heading, speed) == (speed * math.cos(heading_read),
                                                            speed * math.sin(heading_read))
        assert target_velocity_read_back(heading, speed) == pytest.approx((vx, vy), abs=1e-12)


def test_a_detection_sent_as_a_point_reads_back_as_tracker_node_reads_it():
    rng = np.random.default_rng(5)
    for _ in range(20_000):
        distance, bearing = float(rng.uniform(0.2, 12.0)), float(rng.uniform(-math.pi, math.pi))
        x, y = distance * math.cos(bearing), distance * math.sin(bearing)  # scan_messages.target_detections
        assert detection_read_back(distance, bearing) == range_bearing(x, y)
        assert detection_read_back(distance, bearing) == pytest.approx((distance, bearing), abs=1e-12)
