"""viewer: the running graph, live, in Rerun's web viewer on localhost.

    ros2 run twbr_view viewer        # then open the URL it prints (http://127.0.0.1:9090/?url=...)

Subscribes what the map and the plots need (odom, target, obstacles, planner_state, controller_state,
joint_states) best-effort with depth 1: it is not in the lockstep and never holds the graph back; what it
cannot draw in time it drops. It draws on the messages' own stamps (sim time in simulation), so it needs no
clock of its own. Everything it serves listens on 127.0.0.1 only (twbr_view.server).
"""

from __future__ import annotations

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from twbr_common.params import ParamSpec
from twbr_common.ros_params import declare, run_node
from twbr_view.priority import run_at_idle_priority
from twbr_view.scene import VIEWED_TOPICS, RunView, blueprint, feed
from twbr_view.server import ViewerServer, prepare

VIEWER_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("web_port", 9090, "port of the web viewer on 127.0.0.1; 0: a free one", "", 0, 65535),
    ParamSpec("grpc_port", 9876, "port of Rerun's gRPC proxy on 127.0.0.1; 0: a free one", "", 0, 65535),
    ParamSpec("field_period", 1.0, "how often the potential field under the map is redrawn", "s", 0.1, 60.0),
    ParamSpec("map_rate", 30.0, "highest rate of the robot's pose on the map", "Hz", 1.0, 1000.0),
    ParamSpec("series_rate", 50.0, "highest rate of each time series drawn (controller_state comes at 200 Hz)",
              "Hz", 1.0, 1000.0),
    ParamSpec("idle_priority", True, "run at the CPU's idle priority (Linux SCHED_IDLE, else nice 19): the"
              " viewer and its web server take only CPU time the graph leaves and drop what they cannot draw;"
              " false: a normal process"),
    ParamSpec("memory_limit", "25%", "what the web viewer's server may hold for late browsers (Rerun's"
              " --server-memory-limit: bytes with a unit, or a share of RAM)"),
)
LATEST_ONLY = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)


def message_type(name: str) -> type:
    package, _, kind = name.split("/")
    module = __import__(f"{package}.msg", fromlist=[kind])
    return getattr(module, kind)


class Viewer(Node):
    def __init__(self) -> None:
        super().__init__("viewer")
        cfg = declare(self, VIEWER_SPECS)
        priority = run_at_idle_priority() if cfg["idle_priority"] else "normal"
        prepare()
        import rerun as rr

        self.server = ViewerServer(cfg["web_port"], cfg["grpc_port"], cfg["memory_limit"])
        self.rec = rr.RecordingStream("twbr")
        self.rec.connect_grpc(self.server.grpc_url, default_blueprint=blueprint())
        self.view = RunView(self.rec.log, lambda t: self.rec.set_time("sim_time", duration=t),
                            field_period=cfg["field_period"], series_period=1.0 / cfg["series_rate"],
                            pose_period=1.0 / cfg["map_rate"])
        for topic, kind in VIEWED_TOPICS.items():
            self.create_subscription(message_type(kind), topic, lambda msg, topic=topic: feed(self.view, topic, msg),
                                     LATEST_ONLY)
        self.get_logger().info(f"open {self.server.url} in a browser (served on 127.0.0.1 only; CPU priority:"
                               f" {priority})")

    def destroy_node(self) -> None:
        logged = self.view.logged
        self.get_logger().info(f"logged {sum(logged.values())} entities on {len(logged)} paths: "
                               + ", ".join(f"{path} {n}" for path, n in sorted(logged.items())))
        self.rec.flush()
        self.server.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node("viewer", Viewer, args)


if __name__ == "__main__":
    raise SystemExit(main())
