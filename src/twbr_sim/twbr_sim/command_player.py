"""command_player: publishes a scenario's scripted cmd_vel profile (the paper's step inputs) on sim time.

It stands where a planner or a teleop would: the controller cannot tell the difference. With
use_sim_time it follows /clock, publishing at once when the profile changes and otherwise at `rate`
(so cmd_vel never goes stale); without it, it plays the profile from its start on a wall timer.
"""

from __future__ import annotations

from geometry_msgs.msg import Twist, TwistStamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from twbr_common.params import ParamSpec
from twbr_common.ros_io import COMMAND_PUB_QOS, stamp_seconds
from twbr_common.ros_params import declare, run_node
from twbr_sim.scenario import command_at, load_scenario
from twbr_sim.scenario_files import find_scenario

PLAYER_SPECS = (
    ParamSpec("scenario", "step", "scenario file whose `commands` are played: a path, or a name in"
              " share/twbr_config/config/scenarios"),
    ParamSpec("rate", 20.0, "cmd_vel is re-published at least this often while the profile holds", "Hz",
              1.0, 1000.0),
    ParamSpec("enable_stamped_cmd_vel", False, "publish geometry_msgs/TwistStamped instead of Twist"),
    ParamSpec("frame_id", "base_link", "frame of a TwistStamped"),
)


class CommandPlayer(Node):
    def __init__(self) -> None:
        super().__init__("command_player")
        cfg = declare(self, PLAYER_SPECS)
        self.cfg = cfg
        self.scenario = load_scenario(find_scenario(cfg["scenario"]))
        command_at(self.scenario, 0.0)  # loads the compiled profile before the publisher exists: no late step
        self.stamped = cfg["enable_stamped_cmd_vel"]
        self.pub = self.create_publisher(TwistStamped if self.stamped else Twist, "cmd_vel", COMMAND_PUB_QOS)
        self._last: tuple[float, float] | None = None
        self._last_time = -float("inf")
        if self.get_parameter("use_sim_time").value:
            self.create_subscription(Clock, "/clock", lambda m: self._tick(stamp_seconds(m.clock)), 10)
        else:
            start = self.get_clock().now()
            self.create_timer(1.0 / cfg["rate"],
                              lambda: self._tick((self.get_clock().now() - start).nanoseconds * 1e-9))
        self.get_logger().info(f"playing the cmd_vel profile of scenario '{self.scenario.name}'"
                               f" ({len(self.scenario.commands)} steps)")

    def _tick(self, t: float) -> None:
        command = command_at(self.scenario, t)
        # a clock that did not move is a state offered again (a lockstep simulator holding t = 0 until it
        # hears the player): answered again
        if command == self._last and 0.0 < t - self._last_time < 1.0 / self.cfg["rate"]:
            return
        self._last, self._last_time = command, t
        twist = Twist()
        twist.linear.x, twist.angular.z = command
        if self.stamped:
            msg = TwistStamped(twist=twist)
            msg.header.stamp = self.get_clock().now().to_msg()
            msg.header.frame_id = self.cfg["frame_id"]
            self.pub.publish(msg)
        else:
            self.pub.publish(twist)


def main(args: list[str] | None = None) -> int:
    return run_node("command_player", CommandPlayer, args)


if __name__ == "__main__":
    raise SystemExit(main())
