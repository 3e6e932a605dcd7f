"""The driver checks' verdicts on recorded samples: each passes a conforming driver and names a broken one."""

from __future__ import annotations

import numpy as np
import pytest

from twbr_runner.conformance import (
    ScanSample,
    check_frames,
    check_imu_kind,
    check_pitch_sign,
    check_qos,
    check_rate,
    check_response,
    check_scan_fields,
    check_scan_frame,
    check_stamps,
    check_type,
)


def stamps_at(rate: float, seconds: float = 1.0, start: float = 12.0) -> list[float]:
    return list(start + np.arange(round(rate * seconds) + 1) / rate)


def test_rate_of_a_driver_at_its_rate_passes_and_names_the_rate():
    check = check_rate("odom", stamps_at(200.0), 200.0, 0.2)
    assert check.passed and check.detail.startswith("200.0 Hz") and "gap" not in check.detail


@pytest.mark.parametrize("rate", [150.0, 250.0, 100.0])
def test_rate_outside_the_tolerance_fails(rate):
    check = check_rate("imu", stamps_at(rate), 200.0, 0.2)
    assert not check.passed and check.detail.startswith(f"{rate:.1f} Hz")


def test_a_driver_that_skips_samples_fails_and_its_gaps_are_counted():
    """Every 4th sample missing: the clock is right (5 ms) but only 150 samples a second arrive."""
    stamps = [t for k, t in enumerate(stamps_at(200.0)) if k % 4 != 3]
    check = check_rate("joint_states", stamps, 200.0, 0.2)
    assert not check.passed and "50 gap(s) longer than 1.5 periods" in check.detail


def test_rate_ignores_order_and_repeated_stamps():
    """A lockstep simulator may offer its state again with the same stamp; arrival order is the network's."""
    stamps = stamps_at(200.0)
    rng = np.random.default_rng(3)
    check = check_rate("odom", list(rng.permutation(stamps + stamps[:50])), 200.0, 0.2)
    assert check.passed and check.detail.startswith("200.0 Hz")


def test_rate_needs_three_distinct_stamps():
    assert not check_rate("odom", [1.0, 1.0, 1.005], 200.0, 0.2).passed


def test_stamps_unset_or_going_back_fail():
    assert check_stamps("odom", [0.0, 0.0, 0.005, 0.010]).passed  # a simulator's t = 0, offered twice
    assert "2 of 4 messages have no stamp" in check_stamps("odom", [0.0, 0.005, 0.0, 0.0]).detail
    assert "1 stamps go back" in check_stamps("imu", [1.0, 1.005, 1.0, 1.01]).detail
    assert "never advance" in check_stamps("imu", [1.0, 1.0, 1.0]).detail
    assert not check_stamps("imu", [1.0]).passed


def test_type_and_qos_name_what_is_wrong():
    assert check_type("imu", "sensor_msgs/msg/Imu", ["sensor_msgs/msg/Imu"], "publisher").passed
    wrong = check_type("imu", "sensor_msgs/msg/Imu", ["geometry_msgs/msg/Vector3Stamped"], "publisher")
    assert not wrong.passed and "Vector3Stamped" in wrong.detail
    assert "no publisher of imu" in check_type("imu", "sensor_msgs/msg/Imu", [], "publisher").detail
    assert check_qos("odom", [(True, "")]).passed
    bad = check_qos("odom", [(True, ""), (False, "durability mismatch")])
    assert not bad.passed and bad.detail == "durability mismatch"
    assert not check_qos("odom", []).passed


def test_frames_and_imu_kind():
    joints = {("left_wheel_joint", "right_wheel_joint")}
    assert check_frames({("odom", "base_link")}, {"base_link"}, joints).passed
    bad = check_frames({("map", "base_link")}, {"imu_link"}, {("left", "right")})
    assert not bad.passed and "odom frames" in bad.detail and "imu frame" in bad.detail and "joint names" in bad.detail
    assert check_imu_kind({"raw"}).passed and check_imu_kind({"orientation"}).passed
    assert not check_imu_kind({"raw", "orientation"}).passed and not check_imu_kind(set()).passed


def test_pitch_sign_and_response():
    assert check_pitch_sign(0.0, 0.38, 0.0, -0.045, 1.0).passed
    assert "pitch should fall" in check_pitch_sign(0.0, 0.38, 0.0, 0.045, 1.0).detail
    assert "did not speed up" in check_pitch_sign(0.0, 0.0, 0.0, -0.045, 1.0).detail
    assert check_response(0.0, 1.0, 1.0, 0.005).passed
    assert not check_response(0.0, 0.18, 1.0, 0.005).passed
    assert check_response(0.0, 1.0, 1.0, 0.005).detail.endswith(", answered after 0.005 s")
    assert check_response(0.0, 0.0, 1.0, None).detail.endswith(" (no answer within 1 s)")


def scan_sample(ranges, angle_max=None, range_min=0.15, range_max=12.0) -> ScanSample:
    n = len(ranges)
    inc = 2 * np.pi / n
    return ScanSample("laser", -np.pi, -np.pi + (n - 1) * inc if angle_max is None else angle_max, inc,
                      range_min, range_max, tuple(ranges))


def test_a_rep_117_scan_passes_and_each_broken_field_is_named():
    good = [np.inf] * 300 + [2.5] * 50 + [-np.inf] * 10
    check = check_scan_fields([scan_sample(good)])
    assert check.passed and check.detail.startswith("360 beams") and "50 returns" in check.detail
    nan = check_scan_fields([scan_sample(good), scan_sample([np.nan, *good[1:]])])
    assert not nan.passed and "scan 1: 1 NaN" in nan.detail
    zero = check_scan_fields([scan_sample([0.0, *good[1:]])])  # a miss reported as 0 m: below range_min
    assert not zero.passed and "1 finite range(s) outside" in zero.detail
    assert "angle_max" in check_scan_fields([scan_sample(good, angle_max=np.pi + 0.1)]).detail
    assert not check_scan_fields([scan_sample(good, range_min=12.0, range_max=0.15)]).passed
    assert not check_scan_fields([]).passed


def test_the_scan_frame_must_reach_base_link_through_the_transform_tree():
    assert check_scan_frame({"laser"}, {("base_link", "laser"), ("odom", "base_link")}).passed
    chained = check_scan_frame({"laser"}, {("base_link", "mast"), ("mast", "laser")})
    assert chained.passed and chained.detail == "laser <- mast <- base_link"
    assert not check_scan_frame({"laser"}, {("odom", "base_link")}).passed
    assert not check_scan_frame({"laser"}, {("laser", "mast"), ("mast", "laser")}).passed  # a loop ends
    assert not check_scan_frame({"laser", "lidar"}, {("base_link", "laser")}).passed
