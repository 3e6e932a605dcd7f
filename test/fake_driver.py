"""A robot driver that is not sim_node, for the conformance and drop-in tests: wall-clock stepping of the
dynamics core at 200 Hz, stamped with the node's clock, with one deliberate fault if asked.

    python test/fake_driver.py [--fault none|wrong_type|missing_imu|pitch_sign|unstamped|scan_nan|scan_unlinked|deaf]
                               [--burst N] [--command-latency S]

It also has a 2D LiDAR (scan at 10 Hz, base_link -> laser on /tf_static); scan_nan reports its misses as NaN
instead of REP 117's +inf, scan_unlinked leaves the laser frame out of the transform tree; deaf subscribes to
wheel_torque_cmd and never applies it.

--burst N publishes the samples in groups of N, each stamped at its own instant (a driver whose bus
delivers several samples at once): a correct driver, whose rate the checker must still measure.
--command-latency S applies each wheel_torque_cmd S seconds of the driver's time after it came (a motor bus
that slow): a correct driver too, whose response the checker must still see.
"""

from __future__ import annotations

import argparse
import sys
from collections import deque

import rclpy
from geometry_msgs.msg import Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import Imu, JointState, LaserScan
from tf2_msgs.msg import TFMessage

from twbr_common.geometry import quaternion_from_rpy
from twbr_common.params import defaults
from twbr_common.ros_io import COMMAND_QOS, SENSOR_PUB_QOS, TF_STATIC_QOS, to_stamp
from twbr_msgs.msg import WheelTorques
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params
from twbr_sim.scan_messages import laser_scan, laser_transform
from twbr_sim.simulator import SIM_SPECS, Simulator

FAULTS = ("none", "wrong_type", "missing_imu", "pitch_sign", "unstamped", "scan_nan", "scan_unlinked", "deaf")


class FakeDriver(Node):
    def __init__(self, fault: str, burst: int = 1, command_latency: float = 0.0) -> None:
        super().__init__("fake_driver")
        self.fault = fault
        self.command_latency = command_latency
        self._commands: deque[tuple[float, float, float]] = deque()  # (due in the driver's time, left, right)
        cfg = defaults(SIM_SPECS)
        self.sim = Simulator(robot_params(), cfg, None, 0)
        self.pub_odom = self.create_publisher(Odometry, "odom", SENSOR_PUB_QOS)
        imu_type = Vector3Stamped if fault == "wrong_type" else Imu
        self.pub_imu = None if fault == "missing_imu" else self.create_publisher(imu_type, "imu", SENSOR_PUB_QOS)
        self.pub_joints = self.create_publisher(JointState, "joint_states", SENSOR_PUB_QOS)
        self.cfg = cfg
        self.pub_scan = self.create_publisher(LaserScan, "scan", SENSOR_PUB_QOS)
        self._samples_per_scan = round(cfg["publish_rate"] / cfg["lidar.rate"])
        self._samples = 0
        if fault != "scan_unlinked":
            self.pub_static = self.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
            self.pub_static.publish(TFMessage(transforms=[laser_transform(cfg, "base_link", to_stamp(0))]))
        self.create_subscription(WheelTorques, "wheel_torque_cmd", self._on_command, COMMAND_QOS)
        # A sample clock, as a driver's hardware has: each sample stamped at its own instant, and samples a
        # loaded host made late are published late, not skipped (an rclpy timer skips missed periods).
        self._period_ns = round(1e9 / cfg["publish_rate"])
        self._next_ns: int | None = None
        self._burst = burst
        self.create_timer(1.0 / cfg["publish_rate"], self._tick)

    def _on_command(self, msg: WheelTorques) -> None:
        if self.fault != "deaf":
            self._commands.append((self.sim.time + self.command_latency, msg.left, msg.right))

    def _tick(self) -> None:
        now = self.get_clock().now().nanoseconds
        if self._next_ns is None:
            self._next_ns = now
        while self._next_ns + (self._burst - 1) * self._period_ns <= now:
            for _ in range(self._burst):
                self._sample(self._next_ns)
                self._next_ns += self._period_ns

    def _sample(self, stamp_ns: int) -> None:
        while self._commands and self._commands[0][0] <= self.sim.time:
            _, left, right = self._commands.popleft()
            self.sim.offer_command(self.sim.time, left, right)
        self.sim.advance(self.sim.steps_per_publish)
        s = self.sim.state
        stamp = to_stamp(stamp_ns)
        if self.fault == "unstamped":
            stamp.sec, stamp.nanosec = 0, 0
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id, odom.child_frame_id = stamp, "odom", "base_link"
        odom.pose.pose.position.x, odom.pose.pose.position.y = s[dyn.S_XC], s[dyn.S_YC]
        o = odom.pose.pose.orientation
        o.x, o.y, o.z, o.w = quaternion_from_rpy(0.0, s[dyn.S_TH], s[dyn.S_PSI])
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = s[dyn.S_XD], s[dyn.S_PSID]
        self.pub_odom.publish(odom)
        pitch = -s[dyn.S_TH] if self.fault == "pitch_sign" else s[dyn.S_TH]
        if self.fault == "wrong_type":
            self.pub_imu.publish(Vector3Stamped(header=odom.header))
        elif self.pub_imu is not None:
            imu = Imu()
            imu.header.stamp, imu.header.frame_id = stamp, "base_link"
            q = imu.orientation
            q.x, q.y, q.z, q.w = quaternion_from_rpy(0.0, pitch, s[dyn.S_PSI])
            imu.angular_velocity.y = -s[dyn.S_THD] if self.fault == "pitch_sign" else s[dyn.S_THD]
            imu.angular_velocity.z = s[dyn.S_PSID]
            self.pub_imu.publish(imu)
        joints = JointState()
        joints.header.stamp = stamp
        joints.name = ["left_wheel_joint", "right_wheel_joint"]
        joints.position = [float(s[dyn.S_GL]), float(s[dyn.S_GR])]
        joints.velocity = list(self.sim.wheel_rates())
        joints.effort = list(self.sim.wheel_torques())
        self.pub_joints.publish(joints)
        if self._samples % self._samples_per_scan == 0:
            ranges = self.sim.scan()
            if self.fault == "scan_nan":
                ranges[~(ranges < 1e30)] = float("nan")  # misses as NaN: what REP 117 forbids
            self.pub_scan.publish(laser_scan(self.cfg, ranges, stamp))
        self._samples += 1


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--fault", choices=FAULTS, default="none")
    ap.add_argument("--burst", type=int, default=1, help="samples published at once (each at its own stamp)")
    ap.add_argument("--command-latency", type=float, default=0.0, help="driver seconds from a command to its use")
    args = ap.parse_args(remove_ros_args(sys.argv)[1:])
    rclpy.init(args=sys.argv)
    node = FakeDriver(args.fault, args.burst, args.command_latency)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
