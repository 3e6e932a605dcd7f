"""run_scenario: one scenario through the real node graph, recorded, measured and plotted.

    ros2 run twbr_runner run_scenario step            # or: make demo SCENARIO=step
    ros2 run twbr_runner run_scenario config/scenarios/yaw_step.yaml --out runs --seed 3

Starts, as separate processes with their parameter files (what a user does in several terminals): the
recorder (every topic to a rosbag2 MCAP bag), the controller, the scenario's cmd_vel source, and last the
simulator in lockstep, which holds t = 0 until the recorder and the controller are subscribed. All on one
DDS domain on loopback. It shows sim time against the scenario's length, stops at the scenario's end
(its duration, or the target reached when the scenario says so) or at a wall-clock limit, and stops every
process it started, also on Ctrl-C, SIGTERM and failure. Then, from the bag alone, it writes
runs/<scenario>-<time>/metrics.json and the response figures.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import shutil
import signal
import sys
import time
from collections import Counter
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from twbr_common.deploy import JIT_ENV
from twbr_common.graph_watch import FINDING_MARKS
from twbr_common.param_files import KNOWN_NODES, node_parameters
from twbr_common.params import ConfigError, default_of
from twbr_common.paths import config_dir
from twbr_planner.planner_params import METHODS
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
from twbr_planner.planner_params import resolve as resolve_planner
from twbr_runner.animation import run_animation
from twbr_runner.bag_reader import bag_info
from twbr_runner.bag_writer import disk_full_text, is_disk_full
from twbr_runner.figures import potential_figures, response_figures
from twbr_runner.metrics import BagSummary, RunMetrics, compute_metrics, series_from_bag, tracking_metrics
from twbr_runner.spawn import NodeProcess, loopback_env, start_node
from twbr_sim.lidar import LIDAR_SPECS
from twbr_sim.run_report import parse_run_report
from twbr_sim.scenario import PERCEPTIONS, Scenario, load_scenario, run_perception, vary
from twbr_sim.scenario_files import find_scenario
from twbr_sim.target_sensor import TARGET_SENSOR_SPECS
from twbr_tracker.target import MISSION_PRIOR_STD

# With the LiDAR (--perception lidar) the simulator's own obstacles, the truth, are remapped here, and
# tracker_node publishes `obstacles` from the scans, as on a real robot: the planner and the controller's
# collision monitor read what the tracker sees; the metrics and figures judge against the truth.
TRUTH_OBSTACLES = "obstacles_truth"
# The tracker's fused target (from target_detections) goes here, beside the world's `target`, and the
# planner follows it where the robot has a target detector (sim_node's target_sensor; mujoco_driver has
# none, and its planner follows the world's). The tracker is told where the target starts (the seed's
# layout), as a mission hands a robot a goal: before its first sighting the robot heads there.
TRACKED_TARGET = "target_tracked"
# Every topic of the contract, with its type: the recorder subscribes to these before any node starts.
RECORDED_TOPICS = {
    "/clock": "rosgraph_msgs/msg/Clock",
    "/tf": "tf2_msgs/msg/TFMessage",
    "odom": "nav_msgs/msg/Odometry",
    "ground_truth": "nav_msgs/msg/Odometry",
    "imu": "sensor_msgs/msg/Imu",
    "joint_states": "sensor_msgs/msg/JointState",
    "wheel_torque_cmd": "twbr_msgs/msg/WheelTorques",
    "controller_state": "twbr_msgs/msg/ControllerState",
    "sim_status": "twbr_msgs/msg/SimStatus",
    "target": "nav_msgs/msg/Odometry",
    "obstacles": "twbr_msgs/msg/ObstacleArray",
    "world_status": "twbr_msgs/msg/WorldStatus",
    "world_markers": "visualization_msgs/msg/MarkerArray",
    "planner_state": "twbr_msgs/msg/PlannerState",
    "planner_markers": "visualization_msgs/msg/MarkerArray",
    "cmd_vel": "geometry_msgs/msg/Twist",
    "scan": "sensor_msgs/msg/LaserScan",
    TRUTH_OBSTACLES: "twbr_msgs/msg/ObstacleArray",
    "target_detections": "geometry_msgs/msg/PoseArray",
    "tracker_markers": "visualization_msgs/msg/MarkerArray",
    TRACKED_TARGET: "nav_msgs/msg/Odometry",
}
# How long the runner listens for another graph on its domain before it starts one (participants announce
# themselves at once and then every 0.5 s: config/fastdds.xml).
NEIGHBOUR_WAIT_S = 1.5
# How often the runner looks for publishers that are not its graph's on the run's topics, while it runs.
FOREIGN_CHECK_S = 1.0
# tracker_node's last line (TrackerNode.report)
TRACKER_LATENCY = re.compile(r"(\d+) scans tracked; scan -> obstacles median ([0-9.]+) ms, p99 ([0-9.]+) ms")
EXIT_FAILED = 1
# Each runner's own rclpy node is named after when and by which process it started: two runners started
# together see each other's, and the later one refuses (the earlier one runs), where neither graph has
# started a node yet for the other to see.
RUNNER_NODE_PREFIX = "run_scenario_"


@dataclass
class NodeSpec:
    label: str
    package: str
    executable: str
    ros_args: list[str]
    args: list[str] = field(default_factory=list)
    recorded: tuple[str, ...] = ()  # topics it publishes that the recorder must have matched before the sim starts
    niceness: int = 0
    env: dict[str, str] = field(default_factory=dict)  # over the run's environment


def compiled_cores() -> dict[str, str]:
    """The environment of the runner's controller and planner: their cores compiled (TWBR_JIT=on), as the
    simulator's are, unless the caller's TWBR_JIT says otherwise.

    On the robot's own computer the controller runs interpreted by default (twbr_common.deploy: 75 MiB and
    a quarter-second start; the planner compiles by default, twbr_planner.planner_main). A simulation
    workstation runs them compiled: the graph's real-time factor
    rises by a few per cent (benchmarks/README.md, issue 19 part 7); from numba's cache they start in
    0.7 s, and the first run after a source change compiles them (~3 and ~8 s) before the runner starts
    the simulator. Interpreted or compiled, the kernels compute the same numbers (twbr_batch's
    test_interpreted)."""
    return {} if JIT_ENV in os.environ else {JIT_ENV: "on"}


@dataclass
class RunOptions:
    scenario: Path
    out_root: Path = Path("runs")
    seed: int | None = None
    domain: int | None = None
    wall_timeout: float | None = None
    figures: bool = True
    quiet: bool = False
    planner_method: str | None = None  # None: planner.yaml's
    sensors: str = "ideal"  # or "realistic": config/sensors_realistic.yaml over sim.yaml
    driver: str = "sim"  # or "mujoco": twbr_mujoco's mujoco_driver as the robot
    video: Path | None = None  # mujoco: the GIF mujoco_driver renders
    view_port: int | None = None  # the live viewer's web port (twbr_view), None: no viewer
    lockstep_timeout: float | None = None  # [s] wall; None: sim.yaml's
    perception: str | None = None  # "lidar" or "truth"; None: what the scenario says (its default: lidar)


def params_files(config: Path, *names: str) -> list[str]:
    """`--params-file config/<name>` for each name, as ros2 run takes them."""
    out = []
    for name in names:
        out += ["--params-file", str(config / name)]
    return out


def ros_value(value: Any) -> str:
    """A value as `ros2 run ... -p name:=value` reads it (YAML: true/false, numbers, strings)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


SENSORS = ("ideal", "realistic")
DRIVERS = ("sim", "mujoco")
ROBOT_FILES = {"sim": ("sim.yaml", "sim_node"), "mujoco": ("mujoco_driver.yaml", "mujoco_driver")}


def sensor_settings(driver: str, config: Path) -> dict[str, float]:
    """The robot's sensors as its parameter file sets them, the spec's default where it is silent: the
    LiDAR's (`lidar.rate` [Hz], 0: no scan; `lidar.range_max` [m]; ...) and the target detector's
    (`target_sensor.rate` [Hz], 0: the robot has none, as mujoco_driver)."""
    file, node = ROBOT_FILES[driver]
    given = node_parameters(config / file, node)
    specs = (*LIDAR_SPECS, *TARGET_SENSOR_SPECS) if driver == "sim" else LIDAR_SPECS
    settings = {spec.name: float(given.get(spec.name, spec.default)) for spec in specs
                if isinstance(spec.default, (int, float)) and not isinstance(spec.default, bool)}
    settings.setdefault("target_sensor.rate", 0.0)
    return settings


def robot_node(driver: str, config: Path, sensors: str, video: Path | None = None) -> tuple[str, str, list[str]]:
    """(package, executable, parameter arguments) of the robot: sim_node, or mujoco_driver with its own file
    (robot.yaml's physics through its robot_file) and the realistic sensors' settings passed as `-p`."""
    realistic = ["sensors_realistic.yaml"] if sensors == "realistic" else []
    if driver == "sim":
        if video is not None:
            raise ConfigError("--video: only mujoco_driver renders (--driver mujoco)")
        return "twbr_sim", "sim_node", params_files(config, "robot.yaml", "sim.yaml", *realistic)
    video_args = ["-p", f"mujoco.video:={video.resolve()}"] if video is not None else []
    overrides = [a for name in realistic for key, value in node_parameters(config / name, "sim_node").items()
                 for a in ("-p", f"{key}:={ros_value(value)}")]
    return "twbr_mujoco", "mujoco_driver", [*params_files(config, "mujoco_driver.yaml"),
                                            "-p", f"robot_file:={config / 'robot.yaml'}", *overrides,
                                            *video_args]


def plan(scenario: Scenario, scenario_path: Path, config: Path, seed: int, bag_dir: Path,
         planner_method: str | None = None, sensors: str = "ideal", driver: str = "sim",
         video: Path | None = None, view_port: int | None = None,
         lockstep_timeout: float | None = None, perception: str = "truth") -> list[NodeSpec]:
    """The processes of a run, in start order (the simulator last: it waits for its subscribers).
    `perception` lidar: tracker_node between the robot's scan and the planner (run_perception)."""
    lidar = perception == "lidar"
    robot_sensors = sensor_settings(driver, config)
    rate = robot_sensors["lidar.rate"]
    if lidar and rate <= 0.0:
        name, _node = ROBOT_FILES[driver]
        raise ConfigError(f"--perception lidar: the robot has no LiDAR (lidar.rate = {rate:g} in {name}); set"
                          " lidar.rate > 0, or run with --perception truth")
    recorder_topics = [f"{t}:{kind}" for t, kind in RECORDED_TOPICS.items()]
    nodes = [
        # The recorder is not in the control loop: on 2 cores it must not delay the planner's cmd_vel.
        NodeSpec("recorder", "twbr_runner", "recorder", [], ["-o", str(bag_dir), "-a", *recorder_topics],
                 niceness=10),
        NodeSpec("controller", "twbr_control", "controller_node", params_files(config, "controller.yaml"),
                 recorded=("/wheel_torque_cmd", "/controller_state"), env=compiled_cores()),
    ]
    if view_port is not None:
        # Not in the lockstep (best-effort, depth 1) and niced: it draws what it can and never holds the run.
        nodes.insert(1, NodeSpec("viewer", "twbr_view", "viewer", ["-p", f"web_port:={view_port}",
                                                                    "-p", "grpc_port:=0"], niceness=10))
    if scenario.target is not None:
        # what the scenario pins (the paper's scenarios: its method), under --planner-method
        pinned = {**dict(scenario.planner), **({"method": planner_method} if planner_method else {})}
        resolve_planner(pinned, scenario)  # refused before any process starts
        overrides = [a for name, value in pinned.items() for a in ("-p", f"{name}:={ros_value(value)}")]
        if lidar:  # its obstacles come once a scan: a plan at a scan's instant waits for that scan's
            overrides += ["-p", f"obstacles_period:={1.0 / rate!r}"]
            tracker_args = [*params_files(config, "tracker.yaml"), "-r", f"target:={TRACKED_TARGET}"]
            detector_rate = robot_sensors["target_sensor.rate"]
            if detector_rate > 0.0:  # the planner follows what the tracker makes of the detector's looks
                start = vary(scenario, seed).target
                tracker_args += ["-p", f"target.prior_x:={float(start.x)!r}", "-p", f"target.prior_y:={float(start.y)!r}",
                                 "-p", f"target.prior_std:={MISSION_PRIOR_STD!r}"]
                overrides += ["-r", f"target:={TRACKED_TARGET}", "-p", f"world_period:={1.0 / detector_rate!r}"]
            nodes.append(NodeSpec("tracker", "twbr_tracker", "tracker_node", tracker_args,
                                  recorded=("/obstacles", f"/{TRACKED_TARGET}"), env=compiled_cores()))
        nodes.append(NodeSpec("planner", "twbr_planner", "planner_node",
                              [*params_files(config, "planner.yaml"), *overrides],
                              recorded=("/cmd_vel", "/planner_state"), env=compiled_cores()))
    elif scenario.commands:
        nodes.append(NodeSpec("command_player", "twbr_sim", "command_player",
                              [*params_files(config, "command_player.yaml"), "-p", f"scenario:={scenario_path}"],
                              recorded=("/cmd_vel",)))
    # The simulator holds t = 0 until every odom subscriber of the graph (recorder, controller, planner)
    # is matched, and, with a planner, waits for its output at every planning instant as well.
    planner = scenario.target is not None
    planner_rate = node_parameters(config / "planner.yaml", "planner_node").get(
        "rate", default_of(PLANNER_NODE_SPECS, "rate")) if planner else 0.0
    package, executable, robot_args = robot_node(driver, config, sensors, video)
    nodes.append(NodeSpec("sim", package, executable, [
        *robot_args, "-p", f"scenario:={scenario_path}", "-p", f"duration:={scenario.duration}", "-p", f"seed:={seed}",
        "-p", "mode:=lockstep",
        "-p", f"wait_for_subscribers:={(3 if planner else 2) + lidar + (view_port is not None)}",
        "-p", f"lockstep_planner_rate:={float(planner_rate)}",
        *(["-p", "lockstep_commands:=true"] if scenario.commands and not planner else []),
        *(["-p", f"lockstep_timeout:={float(lockstep_timeout)}"] if lockstep_timeout is not None else []),
        *(["-r", f"obstacles:={TRUTH_OBSTACLES}"] if lidar else []),
    ]))
    return nodes


class Progress:
    """The runner's view of the graph, via a small rclpy node: the recorder's status (what it has matched),
    sim time from sim_status and the end condition from world_status."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from rclpy.signals import SignalHandlerOptions

        from twbr_common.executor import new_executor
        from twbr_common.ros_io import WORLD_QOS, stamp_seconds
        from twbr_msgs.msg import RecorderStatus, SimStatus, WorldStatus

        self._rclpy = rclpy
        self.context = rclpy.Context()
        self.claim = (time.time_ns() // 1_000_000, os.getpid())  # (start in ms since the epoch, pid)
        with _SIGNALS.deferred():
            rclpy.init(context=self.context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
            self.node = rclpy.create_node(f"{RUNNER_NODE_PREFIX}{self.claim[0]}_{self.claim[1]}",
                                          context=self.context)
            # sim_status comes ~100 times a wall second: SingleThreadedExecutor cost 7 % of a core here
            self.executor = new_executor(self.context)
            self.executor.add_node(self.node)
        self.sim_time = 0.0
        self.fallen = False
        self.target_reached = False
        self.recorder_matched: dict[str, int] | None = None  # None until the recorder has reported

        def on_status(msg: SimStatus) -> None:
            self.sim_time = max(self.sim_time, stamp_seconds(msg.header.stamp))
            self.fallen |= msg.fallen

        def on_world(msg: WorldStatus) -> None:
            self.target_reached |= msg.target_reached

        def on_recorder(msg: RecorderStatus) -> None:
            self.recorder_matched = dict(zip(msg.topics, msg.matched_publishers, strict=True))

        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        with _SIGNALS.deferred():
            self.node.create_subscription(SimStatus, "sim_status", on_status, WORLD_QOS)
            self.node.create_subscription(WorldStatus, "world_status", on_world, WORLD_QOS)
            self.node.create_subscription(RecorderStatus, "/recorder/status", on_recorder, latched)

    def wait_for_recorder(self, recorder: NodeProcess, topics: Iterable[str], timeout: float) -> None:
        """Until the recorder reports (ready), with a publisher matched on each of `topics`."""
        topics = list(topics)
        deadline = time.monotonic() + timeout

        def ready() -> bool:
            m = self.recorder_matched
            return m is not None and all(m.get(t, 0) > 0 for t in topics)

        while not ready():
            if not recorder.running:
                raise RuntimeError(f"recorder exited with code {recorder.proc.returncode}:\n{_tail(recorder.output)}")
            if time.monotonic() > deadline:
                unmatched = [t for t in topics if (self.recorder_matched or {}).get(t, 0) == 0]
                raise TimeoutError(f"the recorder did not report {'matching ' + ', '.join(unmatched) if topics else 'ready'}"
                                   f" within {timeout:g} s")
            self.spin(0.05)

    def neighbours(self, listen_s: float) -> list[str]:
        """Nodes of another twbr graph, publishers on the contract's topics, and runners started before this
        one (by their node's claim) already on this domain."""
        deadline = time.monotonic() + listen_s
        while time.monotonic() < deadline:
            self.spin(0.1)
        publishers = set()
        with _SIGNALS.deferred():
            graph = self.node.get_node_names_and_namespaces()
            nodes = {f"node {namespace.rstrip('/')}/{name}" for name, namespace in graph
                     if name in (*KNOWN_NODES, "recorder")}
            nodes.update(self.earlier_runners([name for name, _ in graph]))
            for topic in RECORDED_TOPICS:
                for p in self.node.get_publishers_info_by_topic(self.node.resolve_topic_name(topic)):
                    publishers.add(f"{p.node_namespace.rstrip('/')}/{p.node_name} publishing {topic} [{p.topic_type}]")
        return sorted(nodes) + sorted(publishers)

    def earlier_runners(self, names: list[str] | None = None) -> list[str]:
        """Runners among the graph's node `names` (looked up when None) whose node claims an earlier start
        than this one's: also looked at again once this run's nodes are up, for a neighbour that discovery
        did not show within the first look."""
        if names is None:
            with _SIGNALS.deferred():
                names = [name for name, _ in self.node.get_node_names_and_namespaces()]
        return [f"runner {name} (started {(self.claim[0] - other[0]) / 1000:.1f} s before this one)"
                for name in names if (other := runner_claim(name)) is not None and other < self.claim]

    def foreign_publishers(self, ours: Iterable[str]) -> list[str]:
        """Publishers on the run's topics that are none of its nodes (`ours`: their names): a node of
        another name, or a second publisher from a node of one of ours' names (another graph)."""
        ours = set(ours)
        found = []
        with _SIGNALS.deferred():
            for topic in RECORDED_TOPICS:
                resolved = self.node.resolve_topic_name(topic)
                by_node = Counter(f"{p.node_namespace.rstrip('/')}/{p.node_name}"
                                  for p in self.node.get_publishers_info_by_topic(resolved))
                for who, count in sorted(by_node.items()):
                    name = who.rsplit("/", 1)[-1]
                    if name == UNKNOWN_NODE:
                        # An endpoint whose participant is still being discovered (its node's name comes a
                        # moment later) or has just left (our own simulator at the end): named at the next look
                        continue
                    if name not in ours:
                        found.append(f"{who} publishing {resolved}")
                    elif count > 1:
                        found.append(f"a second {who} publishing {resolved} (another graph)")
        return found

    def spin(self, seconds: float) -> None:
        with _SIGNALS.deferred():
            self.executor.spin_once(timeout_sec=seconds)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self._rclpy.try_shutdown(context=self.context)


# The node name the graph API gives an endpoint whose participant's node is not (or no longer) known.
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"


def runner_claim(node_name: str) -> tuple[int, int] | None:
    """(start ms, pid) of another runner's node, from its name; None for any other node."""
    if not node_name.startswith(RUNNER_NODE_PREFIX):
        return None
    parts = node_name[len(RUNNER_NODE_PREFIX):].split("_")
    if len(parts) != 2 or not all(p.isdigit() for p in parts):
        return None
    return int(parts[0]), int(parts[1])


class AnotherGraph(RuntimeError):
    """Another graph's nodes joined the run's domain mid-run: both runs are mixed, and this one ends now."""


class GraphBusy(RuntimeError):
    """Another graph's nodes or publishers are on the run's domain: the two would mix silently."""


class Interrupted(Exception):
    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _SignalLatch:
    """SIGINT and SIGTERM become Interrupted, but never inside rclpy: raised while pybind11 converts a
    message, the exception surfaces as an unrelated error ("Unable to convert call argument")."""

    def __init__(self) -> None:
        self.pending: int | None = None
        self._depth = 0

    def handler(self, signum: int, _frame: Any) -> None:
        if self._depth:
            self.pending = self.pending or signum
        else:
            raise Interrupted(signum)

    @contextmanager
    def deferred(self) -> Iterator[None]:
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
        if not self._depth and self.pending is not None:
            raise Interrupted(self.pending)


_SIGNALS = _SignalLatch()


def _say(opts: RunOptions, text: str, end: str = "\n") -> None:
    if not opts.quiet:
        print(text, end=end, flush=True)


def run(opts: RunOptions) -> tuple[int, Path]:
    """Run, record, measure; returns (exit code, run directory)."""
    scenario_path = find_scenario(str(opts.scenario))
    scenario = load_scenario(scenario_path)
    seed = scenario.seed if opts.seed is None else opts.seed
    domain = opts.domain if opts.domain is not None else int(os.environ.get("ROS_DOMAIN_ID", "0"))
    progress = Progress(domain)  # before anything is written: a run beside another graph is refused whole
    neighbours = progress.neighbours(NEIGHBOUR_WAIT_S)
    if neighbours:
        progress.close()
        raise GraphBusy(f"another graph is already on ROS_DOMAIN_ID {domain}: {'; '.join(neighbours[:6])}"
                        f"{' ...' if len(neighbours) > 6 else ''} (stop it, or run with --domain N)")
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir = opts.out_root / f"{scenario.name}-{stamp}"
    n = 1
    while run_dir.exists():
        n += 1
        run_dir = opts.out_root / f"{scenario.name}-{stamp}-{n}"
    if opts.out_root.resolve() not in run_dir.resolve().parents:
        raise ConfigError(f"invalid scenario name {scenario.name!r}: the run directory would leave --out")
    bag_dir, log_dir = run_dir / "bag", run_dir / "logs"
    perception = run_perception(scenario, opts.perception)
    nodes = plan(scenario, scenario_path.resolve(), config_dir(), seed, bag_dir, opts.planner_method, opts.sensors,
                 opts.driver, opts.video, opts.view_port, opts.lockstep_timeout, perception)
    run_dir.mkdir(parents=True)
    env = loopback_env(domain)
    wall_timeout = opts.wall_timeout or 60.0 + 10.0 * scenario.duration
    (run_dir / "command.txt").write_text(" ".join(sys.argv) + "\n" + "\n".join(
        f"{n.label}: {''.join(f'{k}={v} ' for k, v in n.env.items())}ros2 run {n.package} {n.executable}"
        f" {' '.join(n.args)} --ros-args {' '.join(n.ros_args)}"
        for n in nodes) + "\n")

    _say(opts, f"run_scenario: {scenario.name} (seed {seed}, {scenario.duration:g} s sim time) on ROS_DOMAIN_ID"
               f" {domain} -> {run_dir}")
    procs: dict[str, NodeProcess] = {}
    ours = [spec.executable for spec in nodes]  # each node is named as its executable
    foreign: dict[str, None] = {}  # what was seen, in the order seen
    _SIGNALS.pending = None
    previous = {s: signal.signal(s, _SIGNALS.handler) for s in (signal.SIGINT, signal.SIGTERM)}
    code, reason = 0, "completed"
    busy: GraphBusy | None = None
    wall_start = time.monotonic()
    sim_wall: float | None = None
    try:
        for spec in nodes:
            if spec.label == "sim":
                # Discovery between two processes can take seconds: start the clock only once the
                # recorder hears every other source, so the bag has the run from t = 0.
                progress.wait_for_recorder(procs["recorder"], [t for s in nodes for t in s.recorded], 30.0)
                step_back_if_later(progress, domain)
            procs[spec.label] = start_node(spec.package, spec.executable, spec.ros_args, {**env, **spec.env},
                                           log_dir, spec.label, spec.args, spec.niceness)
            if spec.label == "recorder":
                progress.wait_for_recorder(procs["recorder"], [], 20.0)
                step_back_if_later(progress, domain)  # before any publisher on the contract's topics is up
            if spec.label == "viewer":
                _say(opts, f"  viewer: {viewer_url(procs['viewer'], 30.0)}")
        sim = procs["sim"]
        tty = sys.stdout.isatty()
        last_print = last_check = time.monotonic()
        while sim.running:
            progress.spin(0.1)
            now = time.monotonic()
            if now - last_check >= FOREIGN_CHECK_S:
                last_check = now
                watch_foreign(progress, ours, foreign)
            for label, proc in procs.items():
                if label not in ("sim", "viewer") and not proc.running:
                    raise RuntimeError(f"{label} exited with code {proc.proc.returncode}:\n{_tail(proc.output)}")
            if now - last_print >= (1.0 if tty else 10.0):
                last_print = now
                pct = 100.0 * progress.sim_time / scenario.duration
                _say(opts, f"  sim time {progress.sim_time:6.2f} / {scenario.duration:g} s ({pct:5.1f} %)"
                           f"{'  FALLEN' if progress.fallen else ''}", end="\r" if tty else "\n")
            if scenario.end_on_target and progress.target_reached:
                reason = "target reached"  # the simulator ends the run itself, flushing its last messages
            if now - wall_start > wall_timeout:
                raise TimeoutError(f"wall-clock limit of {wall_timeout:g} s reached at sim time"
                                   f" {progress.sim_time:.2f} s")
        report = parse_run_report(sim.output)  # its own stepping time, without start-up and discovery
        sim_wall = report.wall_s if report else None
        if sim.proc.returncode != 0:  # it ends by itself, at its duration or on the target
            raise RuntimeError(f"sim exited with code {sim.proc.returncode}:\n{_tail(sim.output)}")
        _say(opts, f"  sim time {progress.sim_time:6.2f} / {scenario.duration:g} s: {reason}" + " " * 20)
        progress.spin(0.3)  # let the last messages reach the recorder
    except GraphBusy as e:
        busy = e  # refused before the clock started: nothing measured, nothing kept (below)
    except Interrupted as e:
        code, reason = 128 + e.signum, f"interrupted by {e}"  # the shell's convention: 130 SIGINT, 143 SIGTERM
    except (RuntimeError, TimeoutError, ConfigError) as e:
        code, reason = EXIT_FAILED, f"failed: {e}"
    finally:
        if code == 0 and procs:
            with contextlib.suppress(Exception):  # one last look: a neighbour that joined near the end
                watch_foreign(progress, ours, foreign)
        for s, handler in previous.items():
            signal.signal(s, handler)
        # Stop the sources first, the recorder last, so it sees everything that was published.
        sources = [p for label, p in procs.items() if label != "recorder"]
        for proc in sources:
            proc.interrupt()  # all at once: each takes a moment to shut down
        for proc in sources:
            proc.stop()
        if "recorder" in procs:
            procs["recorder"].stop()
        progress.close()
    if busy is not None:
        shutil.rmtree(run_dir, ignore_errors=True)
        raise busy
    if code == 0:  # what the nodes saw of the graph between the runner's looks (twbr_common.graph_watch)
        for label, proc in procs.items():
            for line in graph_findings(proc.output):
                foreign.setdefault(f"{label} saw {line}", None)
    if foreign and code == 0:
        code = EXIT_FAILED
    if code != 0:
        told = (f"; publishers that are not this run's were on its topics: {'; '.join(list(foreign)[:6])}"
                if foreign and not reason.startswith("failed: another graph") else "")
        print(f"run_scenario: {reason}{told}", file=sys.stderr, flush=True)  # even with --quiet
    tracker_log = procs["tracker"].output if "tracker" in procs else ""
    metrics = analyse(run_dir, bag_dir, scenario, seed, sim_wall, time.monotonic() - wall_start, reason, opts,
                      list(foreign), perception, tracker_log)
    if metrics is None and code == 0:
        code = EXIT_FAILED
    return code, run_dir


def step_back_if_later(progress: Progress, domain: int) -> None:
    """Two runners started together on a loaded host may not see each other in the first look (discovery
    can take seconds): looked at again while the nodes come up, the later one steps back, refused whole."""
    if earlier := progress.earlier_runners():
        raise GraphBusy(f"another graph is starting on ROS_DOMAIN_ID {domain}: {'; '.join(earlier)}"
                        " (stop it, or run with --domain N)")


def graph_findings(output: str) -> list[str]:
    """The neighbours a node reported on its log (twbr_common.graph_watch's error lines)."""
    return [line.split("]: ", 1)[-1] for line in output.splitlines()
            if "[ERROR]" in line and any(mark in line for mark in FINDING_MARKS)]


def watch_foreign(progress: Progress, ours: list[str], seen: dict[str, None]) -> None:
    """Note publishers that are not the run's on its topics; another graph's nodes end the run at once
    (the two mix: each answers the other's states, and neither run means anything)."""
    for line in progress.foreign_publishers(ours):
        seen.setdefault(line, None)
    second = [line for line in seen if line.startswith("a second")]
    if second:
        raise AnotherGraph(f"another graph joined this run's ROS_DOMAIN_ID: {'; '.join(second[:4])}"
                           " (give each run its own --domain)")


def analyse(run_dir: Path, bag_dir: Path, scenario: Scenario, seed: int, wall: float | None, total_wall: float,
            reason: str, opts: RunOptions, foreign: list[str] | None = None, perception: str = "truth",
            tracker_log: str = "") -> RunMetrics | None:
    """metrics.json and figures from the bag alone (plus the wall times the runner measured, and the
    tracker's own latency from its log)."""
    try:
        info = bag_info(bag_dir)
        undecodable: Counter = Counter()
        series = series_from_bag(bag_dir, undecodable)
        if undecodable:  # the recorder keeps what arrived: a neighbour's malformed bytes are not measured
            print(f"run_scenario: left out of the metrics, messages that do not decode as their topic's type:"
                  f" {dict(undecodable)}", file=sys.stderr, flush=True)
        metrics = compute_metrics(series, scenario.name, seed, wall if wall is not None else total_wall,
                                  step_responses=scenario.target is None)
    except Exception as e:  # whatever the recording lacks: report it, keep the bag
        if bag_dir.is_dir() and not (bag_dir / "metadata.yaml").exists():
            print(f"run_scenario: the bag in {bag_dir} was not closed (its recorder stopped early: see"
                  f" {run_dir / 'logs' / 'recorder.err'}): `ros2 run twbr_runner recover_bag {bag_dir} -o <a"
                  " directory with room>` makes it readable", file=sys.stderr, flush=True)
        else:
            print(f"run_scenario: cannot measure the recording in {bag_dir}: {e}", file=sys.stderr, flush=True)
        return None
    metrics.ended_by = reason
    metrics.foreign_publishers = list(foreign or [])
    metrics.perception = perception
    if perception == "lidar":
        lidar = sensor_settings(opts.driver, config_dir())
        metrics.tracking = tracking_metrics(series, lidar["lidar.range_max"], 1.0 / lidar["lidar.rate"])
        latency = TRACKER_LATENCY.search(tracker_log)
        if metrics.tracking is not None and latency:
            metrics.tracking.update(scans_tracked=int(latency[1]), latency_median_ms=float(latency[2]),
                                    latency_p99_ms=float(latency[3]))
    metrics.run_wall_time_s = total_wall  # including start-up, discovery, shutdown and analysis start
    metrics.bag = BagSummary(str(bag_dir), info["storage_identifier"], info["message_count"])
    metrics.messages = {t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]}
    figures = []
    try:
        (run_dir / "metrics.json").write_text(json.dumps(metrics.as_json(), indent=2) + "\n")
        if opts.figures:
            figures = response_figures(series, run_dir, scenario.name)
            if series.planner:
                figures += potential_figures(series, run_dir, scenario.name)
                figures.append(run_animation(series, run_dir, scenario.name))
    except OSError as e:
        if not is_disk_full(e):
            raise
        print(f"run_scenario: {disk_full_text(Path(e.filename or run_dir), e)}: metrics.json or the figures are"
              " missing or incomplete", file=sys.stderr, flush=True)
        return None
    _say(opts, summary(metrics, run_dir, figures))
    if opts.view_port is not None:
        _say(opts, f"  the viewer stopped with the run; replay it: ros2 run twbr_view view_bag {run_dir} --serve")
    return metrics


def summary(metrics: RunMetrics, run_dir: Path, figures: list[Path]) -> str:
    def f(x: Any, fmt: str = ".4g") -> str:
        return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)

    m = metrics.as_json()

    lines = [
        f"{m['scenario']}: {f(m['sim_time_s'], '.2f')} s sim in {f(m['wall_time_s'], '.2f')} s wall"
        f" (real-time factor {f(m['real_time_factor'], '.2f')}), fallen {m['fallen']},"
        f" lockstep timeouts {m['lockstep_timeouts']}",
        f"  pitch [{f(m['pitch_min_rad'])}, {f(m['pitch_max_rad'])}] rad, settles within"
        f" {m['pitch_band_rad']} rad after {f(m['pitch_settle_time_s'], '.3f')} s;"
        f" v rmse {f(m['v_rmse'])} m/s, w rmse {f(m['w_rmse'])} rad/s, max torque {f(m['max_torque_nm'])} N·m"
        f" (largest step {f(m['torque_step_max_nm'])} N·m)",
    ]
    for key, unit in (("velocity_step", "m/s"), ("yaw_rate_step", "rad/s")):
        r = m.get(key)
        if r:
            lines.append(
                f"  {key}: {r['initial']:g} -> {r['final']:g} {unit} at {r['step_time_s']:.3f} s: settles (5 %) in"
                f" {f(r['settle_time_s'], '.3f')} s, overshoot {r['overshoot_pct']:.2f} %, steady-state error"
                f" {r['steady_state_error_pct']:.2f} %, wrong-way dip {r['undershoot']:.4f} {unit}"
            )
    if "reached" in m:
        lines.append(
            f"  reached {m['reached']} at {f(m['time_to_reach_s'], '.2f')} s, collisions {m['collisions']},"
            f" min clearance {f(m['min_clearance_m'], '.3f')} m, pitch after the first {m['transient_s']:g} s"
            f" [{f(m['pitch_after_transient_min_rad'])}, {f(m['pitch_after_transient_max_rad'])}] rad,"
            f" stuck {f(m.get('stuck_time_s'), '.2f')} s"
        )
    if m.get("foreign_publishers"):
        lines.append(f"  NOT THIS GRAPH ALONE: {len(m['foreign_publishers'])} publisher(s) that are not this run's"
                     f" were on its topics ({'; '.join(m['foreign_publishers'][:4])}): these figures are not the"
                     " graph's alone (exit status 1)")
    lines.append(f"  wrote {run_dir / 'metrics.json'}" + (f" and {len(figures)} figures" if figures else "")
                 + f"; bag in {run_dir / 'bag'}")
    return "\n".join(lines)


def viewer_url(viewer: NodeProcess, timeout: float) -> str:
    """The URL the viewer prints once it serves, or why there is none (the run goes on without it)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for line in viewer.output.splitlines():
            if "open http" in line:
                return line.split("open ", 1)[1].split(" ", 1)[0]
        if not viewer.running:
            return f"exited with code {viewer.proc.returncode}, the run goes on without it: {_tail(viewer.output, 3)}"
        time.sleep(0.1)
    return "no URL yet (see logs/viewer.err)"


def _tail(text: str, lines: int = 15) -> str:
    return "\n".join(text.strip().splitlines()[-lines:])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="run_scenario", description=__doc__.split("\n")[0])
    ap.add_argument("scenario", nargs="?", default="dynamic_obstacles",
                    help="scenario name or file (default: dynamic_obstacles)")
    ap.add_argument("--out", type=Path, default=Path("runs"), help="where run directories go (default: runs)")
    ap.add_argument("--seed", type=int, help="override the scenario's seed")
    ap.add_argument("--domain", type=int, help="ROS_DOMAIN_ID (default: the environment's)")
    ap.add_argument("--wall-timeout", type=float, help="give up after this many wall seconds")
    ap.add_argument("--no-figures", action="store_true")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--sensors", choices=SENSORS, default="ideal",
                    help="the simulator's sensors: ideal, or realistic (config/sensors_realistic.yaml: raw IMU with"
                         " noise, bias and delay, 1024-count encoders)")
    ap.add_argument("--driver", choices=DRIVERS, default="sim",
                    help="the robot: sim (sim_node, the ideal model) or mujoco (mujoco_driver: MuJoCo multibody"
                         " physics with wheel-ground contact)")
    ap.add_argument("--video", type=Path, help="with --driver mujoco: render the run into this GIF (offscreen"
                                               " OpenGL: EGL or OSMesa)")
    ap.add_argument("--view", nargs="?", type=int, const=9090, metavar="PORT",
                    help="show the run live in the browser (twbr_view's viewer; web port, default 9090)")
    ap.add_argument("--lockstep-timeout", type=float, metavar="SECONDS",
                    help="wall seconds the simulator waits for a command before stepping without it (counted in"
                         " lockstep_timeouts; default: sim.yaml's 0.5 s). A longer one rides out a host stalled by"
                         " other work; a dead controller then costs that long per step")
    ap.add_argument("--perception", choices=PERCEPTIONS,
                    help="the planner's obstacles: lidar (the robot's scan through tracker_node, as a real robot) or"
                         " truth (the simulator's world); default: the scenario's (the paper's three pin truth,"
                         " every other scenario lidar)")
    ap.add_argument("--planner-method", choices=METHODS,
                    help="the planner's method (default: what the scenario pins, else config/planner.yaml's; docs/planner.md)")
    a = ap.parse_args(argv)
    opts = RunOptions(Path(a.scenario), a.out, a.seed, a.domain, a.wall_timeout, not a.no_figures, a.quiet,
                      a.planner_method, a.sensors, a.driver, a.video, a.view, a.lockstep_timeout, a.perception)
    try:
        code, _ = run(opts)
    except ConfigError as e:
        print(f"run_scenario: {e}", file=sys.stderr)
        return 2
    except GraphBusy as e:
        print(f"run_scenario: refusing to start: {e}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as e:
        if not is_disk_full(e):
            raise
        print(f"run_scenario: {disk_full_text(Path(e.filename or opts.out_root), e)}", file=sys.stderr)
        return EXIT_FAILED
    return code


if __name__ == "__main__":
    raise SystemExit(main())
