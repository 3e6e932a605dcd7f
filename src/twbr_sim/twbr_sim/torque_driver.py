"""torque_driver: answers every odom with a wheel_torque_cmd from a fixed profile (no controller).

`echo` answers with zero torque (the trivial partner that measures the simulator's lockstep cycle
rate); `demo` holds the robot up, turns and pushes it, then lets it fall. The command is stamped with
the state it answers, so it also drives a lockstep simulator.
"""

from __future__ import annotations

from nav_msgs.msg import Odometry
from rclpy.node import Node

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.params import ParamSpec
from twbr_common.ros_io import COMMAND_PUB_QOS, SENSOR_SUB_QOS, stamp_seconds
from twbr_common.ros_params import declare, run_node
from twbr_msgs.msg import WheelTorques
from twbr_sim.torque_profiles import PROFILES, demo_torques

DRIVER_SPECS = (ParamSpec("profile", "echo", "torque profile", choices=PROFILES),)


class TorqueDriver(Node):
    def __init__(self) -> None:
        super().__init__("torque_driver")
        self.profile = declare(self, DRIVER_SPECS)["profile"]
        self.pub = self.create_publisher(WheelTorques, "wheel_torque_cmd", COMMAND_PUB_QOS)
        self.create_subscription(Odometry, "odom", self._on_odom, SENSOR_SUB_QOS)

    def _on_odom(self, msg: Odometry) -> None:
        left = right = 0.0
        if self.profile == "demo":
            o = msg.pose.pose.orientation
            _, pitch, _ = rpy_from_quaternion(o.x, o.y, o.z, o.w)
            left, right = demo_torques(stamp_seconds(msg.header.stamp), pitch, msg.twist.twist.angular.y)
        self.pub.publish(WheelTorques(header=msg.header, left=left, right=right))


def main(args: list[str] | None = None) -> int:
    return run_node("torque_driver", TorqueDriver, args)


if __name__ == "__main__":
    raise SystemExit(main())
