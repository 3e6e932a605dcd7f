"""viewer: the running graph, live, in Rerun's web viewer on localhost.

    ros2 run twbr_view viewer        # then open the URL it prints (http://127.0.0.1:9090/?url=...)

Subscribes what the map and the plots need (odom, target, obstacles, planner_state, controller_state,
joint_states) best-effort with depth 1: it is not in the lockstep and never holds the graph back. It takes
messages in rounds, at most `draw_rate` a second of wall time, the newest of each topic per round: what
arrives between rounds is overwritten unread in the depth-1 queue, so the viewer's CPU time is bounded by
what a screen can show, not by how fast the graph runs (the graph's 200 Hz topics come at ~600-1200 Hz in
lockstep). It draws on the messages' own stamps (sim time in simulation), so it needs no clock of its own.
Everything it serves listens on 127.0.0.1 only (twbr_view.server).
"""

from __future__ import annotations

import signal
import time
from typing import Any

from rclpy.exceptions import InvalidHandle
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription

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
    ParamSpec("draw_rate", 30.0, "rounds per second of wall time in which the viewer takes the newest message"
              " of each topic; what comes between rounds is dropped unread", "Hz", 1.0, 200.0),
    ParamSpec("cpu_budget", 0.1, "share of one core the rounds may use (taking and drawing): a round that"
              " took longer is followed by a longer pause, so a slow machine draws less often", "", 0.01, 1.0),
    ParamSpec("idle_priority", True, "run at the CPU's idle priority (Linux SCHED_IDLE, else nice 19): the"
              " viewer and its web server take only CPU time the graph leaves and drop what they cannot draw;"
              " false: a normal process"),
    ParamSpec("memory_limit", "25%", "what the web viewer's server may hold for late browsers (Rerun's"
              " --server-memory-limit: bytes with a unit, or a share of RAM)"),
)
SERVICE_PERIOD = 0.2  # [s] between looks at the parameter services (a `ros2 param get` waits at most this)
LATEST_ONLY = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)


def message_type(name: str) -> type:
    package, _, kind = name.split("/")
    module = __import__(f"{package}.msg", fromlist=[kind])
    return getattr(module, kind)


def round_delay(spent: float, period: float, budget: float) -> float:
    """[s] from one round's start to the next: `period`, or longer so that `spent` [s of CPU] stays within
    `budget` of one core."""
    return max(period, spent / budget)


def take_newest(sub: Subscription) -> Any | None:
    """What the subscription's queue holds now (depth 1: the newest message), or None."""
    try:
        with sub.handle:
            taken = sub.handle.take_message(sub.msg_type, sub.raw)
    except InvalidHandle:  # destroyed while shutting down
        return None
    return None if taken is None else taken[0]


class Viewer(Node):
    def __init__(self) -> None:
        super().__init__("viewer")
        cfg = declare(self, VIEWER_SPECS)
        self.round_period = 1.0 / cfg["draw_rate"]
        self.cpu_budget = cfg["cpu_budget"]
        self.rounds, self.taken, self.round_cpu = 0, 0, 0.0
        priority = run_at_idle_priority() if cfg["idle_priority"] else "normal"
        prepare()
        import rerun as rr

        self.server = ViewerServer(cfg["web_port"], cfg["grpc_port"], cfg["memory_limit"])
        self.rec = rr.RecordingStream("twbr")
        self.rec.connect_grpc(self.server.grpc_url, default_blueprint=blueprint())
        self.view = RunView(self.rec.log, lambda t: self.rec.set_time("sim_time", duration=t),
                            field_period=cfg["field_period"], series_period=1.0 / cfg["series_rate"],
                            pose_period=1.0 / cfg["map_rate"])
        self.taps = {topic: self.create_subscription(message_type(kind), topic,
                                                     lambda msg, topic=topic: feed(self.view, topic, msg), LATEST_ONLY)
                     for topic, kind in VIEWED_TOPICS.items()}
        self.get_logger().info(f"open {self.server.url} in a browser (served on 127.0.0.1 only; CPU priority:"
                               f" {priority})")

    def run(self) -> None:
        """Rounds `round_period` apart (longer when a round's CPU time would exceed `cpu_budget`): the newest
        message of each topic, taken directly from its depth-1 queue (no wait set: a SingleThreadedExecutor
        round costs ~0.3 ms of Python even when nothing came, and the EventsExecutor would run a callback
        for every message). About every SERVICE_PERIOD the executor serves what else is ready (parameter
        services) without waiting."""
        executor = SingleThreadedExecutor(context=self.context)
        executor.add_node(self)
        next_service = 0.0
        try:
            while self.context.ok():
                begin, cpu = time.monotonic(), time.thread_time()
                self.draw_round()
                spent = time.thread_time() - cpu
                self.rounds += 1
                self.round_cpu += spent
                if begin >= next_service:
                    next_service = begin + SERVICE_PERIOD
                    executor.spin_once(timeout_sec=0.0)
                delay = round_delay(spent, self.round_period, self.cpu_budget)
                time.sleep(max(0.0, begin + delay - time.monotonic()))
        finally:
            executor.remove_node(self)
            executor.shutdown()

    def draw_round(self) -> None:
        for topic, sub in self.taps.items():
            msg = take_newest(sub)
            if msg is not None:
                self.taken += 1
                feed(self.view, topic, msg)

    def destroy_node(self) -> None:
        # The Ctrl-C that stopped the rounds may still be pending in Python (rclpy shuts the context down
        # from C first): it must not cut the last flush short. A SIGTERM or SIGKILL still ends the process.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        logged = self.view.logged
        per_round = 1e3 * self.round_cpu / self.rounds if self.rounds else 0.0
        self.get_logger().info(f"drew {self.rounds} rounds ({self.taken} messages taken), {per_round:.2f} ms of"
                               f" CPU each")
        self.get_logger().info(f"logged {sum(logged.values())} entities on {len(logged)} paths: "
                               + ", ".join(f"{path} {n}" for path, n in sorted(logged.items())))
        self.rec.flush()
        self.rec.disconnect()  # before the server stops: else the SDK reports a severed connection
        self.server.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node("viewer", Viewer, args)


if __name__ == "__main__":
    raise SystemExit(main())
