"""world_node: the scenario's target and obstacles alone, for use beside a real robot's driver.

Publishes target, obstacles, world_markers and (while odometry is fresh) world_status. With
use_sim_time the world's time is the clock's, so it matches a simulator hosting the same scenario;
on wall time it starts when the node does.
"""

from __future__ import annotations

from nav_msgs.msg import Odometry
from rclpy.node import Node
from visualization_msgs.msg import MarkerArray

from twbr_common.graph_watch import GraphWatch
from twbr_common.guard import POSITION_LIMIT
from twbr_common.params import ParamSpec, default_of
from twbr_common.ros_io import MARKER_QOS, SENSOR_SUB_QOS, WORLD_PUB_QOS, stamp_seconds
from twbr_common.ros_params import declare, input_streams, run_node
from twbr_common.timing import Decimator
from twbr_msgs.msg import ObstacleArray, WorldStatus
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario
from twbr_sim.simulator import SIM_SPECS
from twbr_sim.world import World
from twbr_sim.world_messages import obstacles_message, target_message, world_markers, world_status_message

WORLD_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("scenario", "dynamic_obstacles", "scenario file: a path, or a name in share/twbr_config/config/scenarios"),
    ParamSpec("seed", -1, "seed of the target's turns; -1 takes the scenario's", "", -1, 2**31 - 1),
    ParamSpec("rate", default_of(SIM_SPECS, "world_rate"), "rate of target, obstacles and world_status", "Hz", 0.1, 1000.0),
    ParamSpec("marker_rate", 5.0, "rate of the RViz world markers", "Hz", 0.1, 100.0),
    ParamSpec("robot_radius", 0.30, "footprint radius of the robot for collision checks", "m", 0.0, 10.0, low_open=True),
    ParamSpec("odom_timeout", 0.5, "odometry older than this is not assessed (no world_status)", "s", 0.001, 60.0),
    ParamSpec("odom_frame", "odom", "fixed frame of target and obstacles"),
)


class WorldNode(Node):
    def __init__(self) -> None:
        super().__init__("world_node")
        cfg = declare(self, WORLD_SPECS)
        scenario = load_scenario(find_scenario(cfg["scenario"]))
        seed = cfg["seed"] if cfg["seed"] >= 0 else scenario.seed
        self._new_world = lambda: World(scenario, cfg["robot_radius"], seed)
        self.world = self._new_world()
        self.world.warm_up()  # before any publisher: once peers see this node, it answers on time
        self.frame = cfg["odom_frame"]
        self.sim_time = bool(self.get_parameter("use_sim_time").value)
        self._t0: float | None = None
        self.inputs = input_streams(self)
        self._odom_guard = self.inputs.add("odom", cfg["odom_timeout"], limit=POSITION_LIMIT)
        self.inputs.on_restart(self._restart)
        self._robot_xy: tuple[float, float] | None = None
        self._marker_due = Decimator(cfg["marker_rate"])
        self.pub_target = self.create_publisher(Odometry, "target", WORLD_PUB_QOS)
        self.pub_obstacles = self.create_publisher(ObstacleArray, "obstacles", WORLD_PUB_QOS)
        self.pub_status = self.create_publisher(WorldStatus, "world_status", WORLD_PUB_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, "world_markers", MARKER_QOS)
        self.create_subscription(Odometry, "odom", self._on_odom, SENSOR_SUB_QOS)
        self.create_timer(1.0 / cfg["rate"], self._tick)
        self.graph = GraphWatch(self, ["target", "obstacles", "world_status"])
        self.get_logger().info(
            f"world of scenario {scenario.name} (seed {seed}) on {'sim' if self.sim_time else 'wall'} time"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _world_time(self, now: float) -> float | None:
        if self.sim_time:
            return now if now > 0.0 else None  # no /clock yet
        if self._t0 is None:
            self._t0 = now
        return now - self._t0

    def _restart(self) -> None:
        """The clock went back (a restarted simulator): the world starts again with it, from its seed."""
        self.get_logger().warning("clock jumped back: the world restarts from the scenario's start")
        self.world = self._new_world()
        self._robot_xy = None
        self._marker_due.restart()

    def _on_odom(self, msg: Odometry) -> None:
        p = msg.pose.pose.position
        if self.inputs.admit("odom", stamp_seconds(msg.header.stamp), (p.x, p.y), self._now()):
            self._robot_xy = (p.x, p.y)

    def _tick(self) -> None:
        clock_now = self.get_clock().now()
        t = self._world_time(clock_now.nanoseconds * 1e-9)
        if t is None:
            return
        if t < self.world.time:
            self.inputs.restart()
        self.world.advance_to(t, self._robot_xy)
        stamp = clock_now.to_msg()  # the instant the world was sampled at, however long the step took
        target = self.world.target()
        if target is not None:
            self.pub_target.publish(target_message(target, stamp, self.frame))
        self.pub_obstacles.publish(obstacles_message(self.world.obstacles(), stamp, self.frame))
        if self._robot_xy is not None and not self._odom_guard.is_stale(self._now()):
            a = self.world.assess(*self._robot_xy)
            self.pub_status.publish(world_status_message(a, self.world.collision_count, stamp, self.frame))
        if self._marker_due.due(t) and self.pub_markers.get_subscription_count():  # only while a viewer listens
            self.pub_markers.publish(
                world_markers(target, self.world.obstacles(), self.world.capture_radius, stamp, self.frame)
            )


def main(args: list[str] | None = None) -> int:
    return run_node("world_node", WorldNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
