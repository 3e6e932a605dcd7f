"""check_driver: checks a running robot driver against the interface contract (docs/interfaces.md).

    ros2 run twbr_runner check_driver [--rate 200] [--tolerance 0.2] [--torque 1.0] [--scan-rate 10 | --no-scan]

Run it beside the driver alone (no controller): it answers every odom with a wheel_torque_cmd stamped
with that state (zero torque, which also steps a lockstep simulator), then applies a short forward torque
pulse. On a real robot, put it on a stand first: the pulse spins the wheels and nothing balances it. It
prints one PASS/FAIL line per check and exits 1 if any check fails (2 when nothing answers at all).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import defaultdict
from statistics import mean

import rclpy
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSCompatibility, QoSProfile, ReliabilityPolicy, qos_check_compatible
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import Imu, JointState, LaserScan
from tf2_msgs.msg import TFMessage

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.params import default_of
from twbr_common.ros_io import COMMAND_PUB_QOS, SENSOR_SUB_QOS, TF_STATIC_QOS, stamp_seconds
from twbr_msgs.msg import WheelTorques
from twbr_runner.conformance import (
    ANSWER_LIMIT_S,
    COMMAND_TOPIC,
    SCAN_TOPIC,
    SENSOR_TOPICS,
    Check,
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
from twbr_sim.lidar import LIDAR_SPECS
from twbr_sim.simulator import SIM_SPECS

# What the checker listens with: best effort, as our nodes' SENSOR_SUB_QOS (so it matches every driver
# theirs match), but with 5 s of samples at 200 Hz queued instead of 5. A driver that publishes the samples
# a busy moment made late all at once, or a checker the host holds back for 25 ms, must not lose samples
# in the checker's own queue: the rate check counts what arrives.
LISTEN_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)
# Wall seconds, and odom messages, arriving with a stamp that never advances: the driver's clock is stuck
# (or unset), and waiting the whole timeout for its time to pass would only delay the failed stamps check.
STALLED_S = 2.0
STALLED_MESSAGES = 20


class DriverChecker(Node):
    def __init__(self, scan: bool) -> None:
        super().__init__("check_driver")
        self.scan = scan  # the driver has a 2D LiDAR on `scan` (docs/interfaces.md)
        self.scans: list[ScanSample] = []
        self.links: set[tuple[str, str]] = set()
        self.stamps: dict[str, list[float]] = defaultdict(list)
        self.odom_frames: set[tuple[str, str]] = set()
        self.imu_frames: set[str] = set()
        self.imu_kinds: set[str] = set()
        self.joint_names: set[tuple[str, ...]] = set()
        self.last_speed = 0.0
        self.last_pitch = 0.0
        self.efforts: list[tuple[float, float]] = []  # (stamp, mean of the two wheels' effort)
        self.reports_effort = False
        self.torque = 0.0
        self._advanced_at = time.monotonic()  # wall time of the odom stamp's last advance
        self._since_advance = 0  # odom messages since
        self.pub = self.create_publisher(WheelTorques, COMMAND_TOPIC[0], COMMAND_PUB_QOS)

    def graph_checks(self) -> list[Check]:
        checks = []
        names = dict(self.get_topic_names_and_types())
        for topic, expected in self.sensor_topics().items():
            full = self.resolve_topic_name(topic)
            publishers = self.get_publishers_info_by_topic(full)
            checks.append(check_type(topic, expected, sorted(set(names.get(full, []))) if publishers else [],
                                     "publisher"))
            checks.append(check_qos(topic, [_compatible(p.qos_profile, SENSOR_SUB_QOS) for p in publishers]))
        topic, expected = COMMAND_TOPIC
        subscribers = self.get_subscriptions_info_by_topic(self.resolve_topic_name(topic))
        checks.append(check_type(topic, expected, sorted({s.topic_type for s in subscribers}), "subscriber"))
        # Our publisher's profile as the graph reports it (defaults spelled out the same way as the driver's).
        ours = [p.qos_profile for p in self.get_publishers_info_by_topic(self.resolve_topic_name(topic))
                if p.node_name == self.get_name()]
        mine = ours[0] if ours else COMMAND_PUB_QOS
        checks.append(check_qos(topic, [_compatible(mine, s.qos_profile) for s in subscribers]))
        return checks

    def sensor_topics(self) -> dict[str, str]:
        return {**SENSOR_TOPICS, **(dict([SCAN_TOPIC]) if self.scan else {})}

    def listen(self) -> None:
        self.create_subscription(Odometry, "odom", self._on_odom, LISTEN_QOS)
        self.create_subscription(Imu, "imu", self._on_imu, LISTEN_QOS)
        self.create_subscription(JointState, "joint_states", self._on_joints, LISTEN_QOS)
        if self.scan:
            self.create_subscription(LaserScan, SCAN_TOPIC[0], self._on_scan, LISTEN_QOS)
            self.create_subscription(TFMessage, "/tf_static", self._on_tf, TF_STATIC_QOS)
            self.create_subscription(TFMessage, "/tf", self._on_tf, LISTEN_QOS)

    def _on_scan(self, msg: LaserScan) -> None:
        self.stamps[SCAN_TOPIC[0]].append(stamp_seconds(msg.header.stamp))
        self.scans.append(ScanSample(msg.header.frame_id, msg.angle_min, msg.angle_max, msg.angle_increment,
                                     msg.range_min, msg.range_max, tuple(msg.ranges)))

    def _on_tf(self, msg: TFMessage) -> None:
        self.links.update((t.header.frame_id, t.child_frame_id) for t in msg.transforms)

    def _on_odom(self, msg: Odometry) -> None:
        stamp = stamp_seconds(msg.header.stamp)
        if stamp > self.driver_time():
            self._advanced_at = time.monotonic()
            self._since_advance = 0
        else:
            self._since_advance += 1
        self.stamps["odom"].append(stamp)
        self.odom_frames.add((msg.header.frame_id, msg.child_frame_id))
        self.last_speed = msg.twist.twist.linear.x
        self.pub.publish(WheelTorques(header=msg.header, left=self.torque, right=self.torque))

    def _on_imu(self, msg: Imu) -> None:
        self.stamps["imu"].append(stamp_seconds(msg.header.stamp))
        self.imu_frames.add(msg.header.frame_id)
        raw = msg.orientation_covariance[0] == -1.0
        self.imu_kinds.add("raw" if raw else "orientation")
        if raw:  # no orientation: the accelerometer's gravity direction gives the pitch
            a = msg.linear_acceleration
            self.last_pitch = math.atan2(-a.x, a.z)
        else:
            o = msg.orientation
            self.last_pitch = rpy_from_quaternion(o.x, o.y, o.z, o.w)[1]

    def _on_joints(self, msg: JointState) -> None:
        self.stamps["joint_states"].append(stamp_seconds(msg.header.stamp))
        self.joint_names.add(tuple(msg.name))
        if len(msg.effort) >= 2:
            self.reports_effort = True
            self.efforts.append((stamp_seconds(msg.header.stamp), mean(msg.effort[:2])))

    def answered_at(self, effort: float) -> float | None:
        """The driver's stamp of its first sample whose effort reached `effort`, if any."""
        return next((t for t, e in self.efforts if e >= effort), None)

    def driver_time(self) -> float:
        return self.stamps["odom"][-1] if self.stamps["odom"] else 0.0

    def clock_stalled(self) -> bool:
        """Odom keeps arriving but its stamp has not advanced for STALLED_S wall seconds."""
        return self._since_advance >= STALLED_MESSAGES and time.monotonic() - self._advanced_at >= STALLED_S

    def waited(self, since: float, driver_seconds: float) -> bool:
        """`driver_seconds` of the driver's time have passed since its time `since`, or never will."""
        return self.driver_time() - since >= driver_seconds or self.clock_stalled()


def _compatible(publisher: QoSProfile, subscription: QoSProfile) -> tuple[bool, str]:
    verdict, reason = qos_check_compatible(publisher, subscription)
    return verdict != QoSCompatibility.ERROR, reason


def spin_until(node: Node, condition, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        rclpy.spin_once(node, timeout_sec=0.02)
    return condition()


def run_checks(node: DriverChecker, args: argparse.Namespace) -> list[Check]:
    # The driver's endpoints, as the graph shows them.
    spin_until(node, lambda: all(node.count_publishers(t) for t in node.sensor_topics())
               and node.count_subscribers(COMMAND_TOPIC[0]), args.timeout)
    time.sleep(0.2)
    checks = node.graph_checks()
    # Passive: zero torque answering each state, for `window` seconds of the driver's time.
    node.listen()
    if not spin_until(node, lambda: len(node.stamps["odom"]) > 2, args.timeout):
        return [*checks, Check("odom received", False, f"nothing within {args.timeout:g} s")]
    start = node.driver_time()
    spin_until(node, lambda: node.waited(start, args.window), args.timeout + 5 * args.window)
    for topic in SENSOR_TOPICS:
        checks.append(check_stamps(topic, node.stamps[topic]))
        checks.append(check_rate(topic, node.stamps[topic], args.rate, args.tolerance))
    checks.append(check_frames(node.odom_frames, node.imu_frames, node.joint_names))
    checks.append(check_imu_kind(node.imu_kinds))
    if node.scan:
        scan = SCAN_TOPIC[0]
        checks.append(check_stamps(scan, node.stamps[scan]))
        checks.append(check_rate(scan, node.stamps[scan], args.scan_rate, args.tolerance))
        checks.append(check_scan_fields(node.scans))
        checks.append(check_scan_frame({s.frame for s in node.scans}, node.links))
    # Active: a forward torque pulse of `pulse` driver seconds from the driver's first answer (its effort
    # halfway to the command), then zero torque again; a driver that reports no effort is timed from the
    # command, one that never answers is judged after ANSWER_LIMIT_S.
    effort_before = mean(e for _, e in node.efforts[-20:]) if node.efforts else 0.0
    v0, p0 = node.last_speed, node.last_pitch
    node.efforts.clear()
    node.torque = args.torque
    t0 = node.driver_time()
    answer = effort_before + 0.5 * args.torque

    def pulse_over() -> bool:
        start = node.answered_at(answer) if node.reports_effort else t0
        return node.waited(t0, ANSWER_LIMIT_S) if start is None else node.waited(start, args.pulse)

    spin_until(node, pulse_over, args.timeout + 5 * (ANSWER_LIMIT_S + args.pulse))
    v1, p1 = node.last_speed, node.last_pitch
    start = node.answered_at(answer)
    during = [e for t, e in node.efforts if start is None or t >= start + 0.5 * args.pulse]
    effort_during = mean(during) if during else 0.0
    node.torque = 0.0
    spin_until(node, lambda: False, 0.2)
    checks.append(check_pitch_sign(v0, v1, p0, p1, args.torque))
    checks.append(check_response(effort_before, effort_during, args.torque,
                                 None if start is None else start - t0))
    return checks


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    ap = argparse.ArgumentParser(prog="check_driver", description=__doc__.split("\n")[0])
    ap.add_argument("--rate", type=float, default=default_of(SIM_SPECS, "publish_rate"),
                    help="expected rate of odom, imu, joint_states [Hz]")
    ap.add_argument("--tolerance", type=float, default=0.2, help="allowed relative rate error (default 0.2)")
    ap.add_argument("--window", type=float, default=1.0, help="driver seconds of passive listening")
    ap.add_argument("--torque", type=float, default=1.0, help="forward torque pulse on both wheels [N·m]")
    ap.add_argument("--pulse", type=float, default=0.1, help="length of the torque pulse, driver seconds from the driver's"
                    " first answer in its effort (up to 1 s after the command); judged on the pulse's second half")
    ap.add_argument("--timeout", type=float, default=15.0, help="wall seconds to wait for the driver")
    ap.add_argument("--scan-rate", type=float, default=default_of(LIDAR_SPECS, "lidar.rate"),
                    help="expected rate of scan [Hz]")
    ap.add_argument("--no-scan", action="store_true", help="the driver has no 2D LiDAR: skip the scan checks")
    args = ap.parse_args(remove_ros_args(argv)[1:])
    rclpy.init(args=argv)
    node = DriverChecker(scan=not args.no_scan)
    try:
        checks = run_checks(node, args)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    for check in checks:
        print(check.line(), flush=True)
    failed = [c for c in checks if not c.passed]
    print(f"{len(checks) - len(failed)} of {len(checks)} checks passed", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
