"""sim_node and world_node as real processes over DDS, checked against the cores they wrap."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from conftest import CONFIG, PATIENT_LOCKSTEP, assert_refused_at_start
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, LaserScan
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.params import defaults
from twbr_common.ros_io import TF_STATIC_QOS, stamp_ns, to_stamp
from twbr_msgs.msg import ObstacleArray, SimStatus, WheelTorques, WorldStatus
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.simulator import SIM_SPECS, Simulator
from twbr_sim.world import World

pytestmark = pytest.mark.e2e

RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
SIM_PARAMS = ("robot.yaml", "sim.yaml")


def torque_for(odom: Odometry) -> tuple[float, float]:
    """A pitch PD that keeps the robot up, plus an asymmetric wobble so that every state variable moves."""
    o = odom.pose.pose.orientation
    _, pitch, _ = rpy_from_quaternion(o.x, o.y, o.z, o.w)
    t = stamp_ns(odom.header.stamp) * 1e-9
    balance = 30.0 * pitch + 4.0 * odom.twist.twist.angular.y
    return balance + 0.6 * math.sin(7.0 * t) + 0.1, balance + 0.5 * math.cos(5.0 * t) - 0.1


class Recorder:
    def __init__(self, ros, topics: dict[str, type]) -> None:
        self.msgs: dict[str, list] = {name: [] for name in topics}
        for name, kind in topics.items():
            ros.node.create_subscription(kind, name, self.msgs[name].append, RELIABLE)


def test_published_state_equals_the_core_driven_by_the_same_commands(launch, ros):
    duration = 2.0
    sim = launch("twbr_sim", "sim_node", "-p", f"duration:={duration}", "-p", "scenario:=dynamic_obstacles",
                 *PATIENT_LOCKSTEP, params=SIM_PARAMS)
    rec = Recorder(ros, {"imu": Imu, "joint_states": JointState, "sim_status": SimStatus,
                         "/tf": TFMessage, "target": Odometry, "obstacles": ObstacleArray,
                         "world_markers": MarkerArray, "/clock": Clock, "scan": LaserScan})
    static: list[TFMessage] = []
    ros.node.create_subscription(TFMessage, "/tf_static", static.append, TF_STATIC_QOS)
    pub = ros.node.create_publisher(WheelTorques, "wheel_torque_cmd", RELIABLE)
    odoms: list[Odometry] = []

    def on_odom(msg: Odometry) -> None:
        odoms.append(msg)
        left, right = torque_for(msg)
        pub.publish(WheelTorques(header=msg.header, left=left, right=right))

    ros.node.create_subscription(Odometry, "odom", on_odom, RELIABLE)
    assert ros.spin_until(lambda: sim.proc.poll() is not None, 30.0), sim.output
    ros.spin_for(0.3)
    assert sim.proc.returncode == 0, sim.output

    # Replay the same exchange on the core.
    scenario = load_scenario(CONFIG / "scenarios" / "dynamic_obstacles.yaml")
    core = Simulator(robot_params(), defaults(SIM_SPECS), scenario, seed=scenario.seed)
    by_stamp = {stamp_ns(m.header.stamp): m for m in odoms}
    imus = {stamp_ns(m.header.stamp): m for m in rec.msgs["imu"]}
    joints = {stamp_ns(m.header.stamp): m for m in rec.msgs["joint_states"]}
    scans = {stamp_ns(m.header.stamp): m for m in rec.msgs["scan"]}
    n_states = round(duration * 200) + 1
    assert len(by_stamp) == n_states
    assert sorted(scans) == [k * 100_000_000 for k in range(round(duration * 10) + 1)]  # 10 Hz of sim time
    for k in range(n_states):
        ns = k * 5_000_000
        odom, imu, js = by_stamp[ns], imus[ns], joints[ns]
        s = core.state
        pose, twist = odom.pose.pose, odom.twist.twist
        assert (pose.position.x, pose.position.y) == pytest.approx((s[dyn.S_XC], s[dyn.S_YC]), abs=1e-12)
        _, pitch, yaw = rpy_from_quaternion(pose.orientation.x, pose.orientation.y, pose.orientation.z,
                                            pose.orientation.w)
        assert (pitch, yaw) == pytest.approx((s[dyn.S_TH], s[dyn.S_PSI]), abs=1e-9)
        assert (twist.linear.x, twist.angular.y, twist.angular.z) == pytest.approx(
            (s[dyn.S_XD], s[dyn.S_THD], s[dyn.S_PSID]), abs=1e-12)
        reading = core.imu()
        av, la = imu.angular_velocity, imu.linear_acceleration
        assert (av.x, av.y, av.z) == pytest.approx(reading.angular_velocity, abs=1e-12)
        assert (la.x, la.y, la.z) == pytest.approx(reading.linear_acceleration, abs=1e-12)
        assert list(js.name) == ["left_wheel_joint", "right_wheel_joint"]
        assert list(js.position) == pytest.approx([s[dyn.S_GL], s[dyn.S_GR]], abs=1e-12)
        assert list(js.velocity) == pytest.approx(list(core.wheel_rates()), abs=1e-12)
        assert list(js.effort) == pytest.approx(list(core.wheel_torques()), abs=1e-12)
        if ns in scans:  # the scan the core casts from this state, noise and dropouts drawn alike
            assert np.array_equal(np.array(scans[ns].ranges, dtype=np.float32), core.scan().astype(np.float32))
        core.offer_command(ns * 1e-9, *torque_for(odom))  # what the simulator received for this state
        core.advance(5)
    # The robot really moved and turned, upright.
    end = by_stamp[(n_states - 1) * 5_000_000]
    assert math.hypot(end.pose.pose.position.x, end.pose.pose.position.y) > 5e-3
    assert abs(end.pose.pose.orientation.z) > 0.1
    assert odoms[-1].header.frame_id == "odom" and odoms[-1].child_frame_id == "base_link"
    assert rec.msgs["imu"][-1].header.frame_id == "base_link"
    tf = rec.msgs["/tf"][-1].transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("odom", "base_link")
    assert rec.msgs["/clock"][-1].clock == to_stamp(round(duration * 1e9))
    scan = rec.msgs["scan"][-1]
    assert scan.header.frame_id == "laser" and len(scan.ranges) == 360 and scan.scan_time == pytest.approx(0.1)
    assert (scan.angle_min, scan.angle_increment) == pytest.approx((-math.pi, math.radians(1.0)))
    assert scan.angle_max == pytest.approx(scan.angle_min + 359 * scan.angle_increment)
    assert (scan.range_min, scan.range_max) == pytest.approx((0.15, 12.0))
    ranges = np.array(scan.ranges)
    assert np.isposinf(ranges).any() and not np.isnan(ranges).any()  # REP 117: no return is +inf
    finite = ranges[np.isfinite(ranges)]
    assert len(finite) > 0 and finite.min() >= 0.15 and finite.max() <= 12.0
    laser = static[-1].transforms[0]
    assert (laser.header.frame_id, laser.child_frame_id, laser.transform.translation.z) == ("base_link", "laser",
                                                                                           pytest.approx(0.25))
    status = rec.msgs["sim_status"][-1]
    assert status.lockstep_timeouts == 0 and status.commands_rejected == 0 and not status.fallen
    assert status.steps == round(duration * 1000)
    # The world rode along: target and obstacles as the world core has them at the stamp.
    world = World(scenario, 0.3, scenario.seed)
    last = rec.msgs["obstacles"][-1]
    world.advance_to(stamp_ns(last.header.stamp) * 1e-9)
    published = [v for o in last.obstacles for v in (o.id, o.position.x, o.position.y, o.radius)]
    assert published == pytest.approx([v for o in world.obstacles() for v in (o.id, o.x, o.y, o.radius)], abs=1e-12)
    target = next(m for m in rec.msgs["target"] if m.header.stamp == last.header.stamp)
    assert (target.pose.pose.position.x, target.pose.pose.position.y) == pytest.approx(
        (world.target().x, world.target().y), abs=1e-12)
    assert len(rec.msgs["world_markers"]) >= 2


def test_lockstep_takes_no_step_without_a_command_and_counts_timeouts(launch, ros):
    sim = launch("twbr_sim", "sim_node", "-p", "lockstep_timeout:=0.05", params=SIM_PARAMS)
    rec = Recorder(ros, {"sim_status": SimStatus})
    pub = ros.node.create_publisher(WheelTorques, "wheel_torque_cmd", RELIABLE)
    odoms: list[Odometry] = []
    answering = {"on": False, "count": 0}

    def on_odom(msg: Odometry) -> None:
        odoms.append(msg)
        if answering["on"]:
            answering["count"] += 1
            pub.publish(WheelTorques(header=msg.header, left=0.0, right=0.0))

    ros.node.create_subscription(Odometry, "odom", on_odom, RELIABLE)
    # Nobody answers: the initial state is offered again, and sim time stays at 0.
    assert ros.spin_until(lambda: len(odoms) >= 5, 20.0), sim.output
    assert {stamp_ns(m.header.stamp) for m in odoms} == {0}
    # Answer 40 states: 40 steps of 5 ms, no timeouts.
    answering["on"] = True
    assert ros.spin_until(lambda: answering["count"] >= 40, 10.0)
    answering["on"] = False
    ros.spin_for(0.01)
    answered_until = max(stamp_ns(m.header.stamp) for m in odoms)
    assert answered_until >= 39 * 5_000_000
    stamps = sorted({stamp_ns(m.header.stamp) for m in odoms})
    assert all(b - a == 5_000_000 for a, b in itertools.pairwise(stamps))
    # Silence: each exchange now waits 50 ms and steps without a command, counted; after 0.1 s of sim time
    # the last command is stale and the motors get zero torque.
    assert ros.spin_until(
        lambda: rec.msgs["sim_status"] and rec.msgs["sim_status"][-1].lockstep_timeouts >= 25, 10.0
    ), sim.output
    status = rec.msgs["sim_status"][-1]
    assert status.command_stale
    assert stamp_ns(status.header.stamp) > answered_until


def test_bad_commands_are_dropped_and_saturation_is_flagged(launch, ros):
    sim = launch("twbr_sim", "sim_node", "-p", "lockstep_timeout:=0.2", params=SIM_PARAMS)
    rec = Recorder(ros, {"sim_status": SimStatus, "joint_states": JointState})
    pub = ros.node.create_publisher(WheelTorques, "wheel_torque_cmd", RELIABLE)
    seen = []

    def on_odom(msg: Odometry) -> None:
        seen.append(msg)
        k = len(seen)
        if k % 4 == 1:
            pub.publish(WheelTorques(header=msg.header, left=math.nan, right=1.0))  # dropped
        pub.publish(WheelTorques(header=msg.header, left=40.0 if k > 10 else 0.0, right=0.0))

    ros.node.create_subscription(Odometry, "odom", on_odom, RELIABLE)
    assert ros.spin_until(lambda: len(seen) >= 30, 20.0), sim.output
    ros.spin_until(lambda: rec.msgs["sim_status"] and rec.msgs["sim_status"][-1].torque_saturated, 5.0)
    status = rec.msgs["sim_status"][-1]
    assert status.torque_saturated
    assert status.commands_rejected >= 5
    assert status.lockstep_timeouts == 0  # the good command of every exchange still arrived
    assert max(abs(m.effort[0]) for m in rec.msgs["joint_states"]) <= 15.0 + 1e-6
    assert "dropped wheel_torque_cmd: non-finite value" in sim.stderr
    assert "past the motor limit 15 N*m: clipped" in sim.stderr


def test_realtime_mode_follows_the_wall_clock_and_zeroes_a_missing_command(launch, ros):
    sim = launch("twbr_sim", "sim_node", "-p", "mode:=realtime", params=SIM_PARAMS)
    rec = Recorder(ros, {"sim_status": SimStatus, "/clock": Clock})
    assert ros.spin_until(lambda: len(rec.msgs["/clock"]) > 0, 20.0), sim.output
    first = stamp_ns(rec.msgs["/clock"][-1].clock) * 1e-9
    ros.spin_for(2.0)
    elapsed = stamp_ns(rec.msgs["/clock"][-1].clock) * 1e-9 - first
    assert 1.0 < elapsed < 2.5  # loose: a functional check of the mode, not a benchmark
    status = rec.msgs["sim_status"][-1]
    assert status.command_stale and status.commands_received == 0
    assert status.steps == round(stamp_ns(status.header.stamp) * 1e-6)  # 1 kHz physics in sim time


def test_world_node_beside_another_robot(launch, ros):
    world = launch("twbr_sim", "world_node", "-p", "scenario:=dynamic_obstacles", params=("world.yaml",))
    rec = Recorder(ros, {"target": Odometry, "obstacles": ObstacleArray, "world_status": WorldStatus,
                         "world_markers": MarkerArray})
    odom_pub = ros.node.create_publisher(Odometry, "odom", RELIABLE)
    assert ros.spin_until(lambda: len(rec.msgs["obstacles"]) >= 10, 20.0), world.output
    a, b = rec.msgs["obstacles"][0], rec.msgs["obstacles"][-1]
    dt = (stamp_ns(b.header.stamp) - stamp_ns(a.header.stamp)) * 1e-9
    o1a, o1b = a.obstacles[0], b.obstacles[0]
    moved = math.hypot(o1b.position.x - o1a.position.x, o1b.position.y - o1a.position.y)
    # Stamps are the node's wall clock at publication, the world's time is sampled just before: ms jitter.
    assert moved == pytest.approx(0.28 * dt, abs=0.28 * 0.01)
    ta, tb = rec.msgs["target"][-2], rec.msgs["target"][-1]
    assert tb.twist.twist.linear.x == 0.25 and abs(tb.twist.twist.angular.z) <= 1.0
    assert ta.header.frame_id == "odom"

    def robot_at(x: float, y: float) -> None:
        m = Odometry()
        m.header.stamp = ros.node.get_clock().now().to_msg()
        m.header.frame_id = "odom"
        m.pose.pose.position.x, m.pose.pose.position.y = x, y
        odom_pub.publish(m)

    def latest_status(pred) -> bool:
        return bool(rec.msgs["world_status"]) and pred(rec.msgs["world_status"][-1])

    obstacle = rec.msgs["obstacles"][-1].obstacles[0]
    for _ in range(20):
        robot_at(obstacle.position.x, obstacle.position.y)
        if ros.spin_until(lambda: latest_status(lambda s: s.collision), 0.1):
            break
    status = rec.msgs["world_status"][-1]
    assert status.collision and status.collision_obstacle_id == 1 and status.clearance < 0
    for _ in range(20):
        robot_at(-20.0, -20.0)
        if ros.spin_until(lambda: latest_status(lambda s: not s.collision), 0.1):
            break
    status = rec.msgs["world_status"][-1]
    assert not status.collision and status.clearance > 10.0 and status.collision_count == 1
    assert rec.msgs["world_markers"]


BAD_STARTS = [
    ("sim_node", ["-p", "wheel_radius:=-0.1"], "invalid parameter 'wheel_radius' = -0.1", "(0, 5] m"),
    ("sim_node", ["-p", "wheel_radius:=big"], "invalid parameter 'wheel_radius' = 'big'", "(0, 5] m"),
    ("sim_node", ["-p", "mode:=fast"], "invalid parameter 'mode' = 'fast'", "one of 'lockstep', 'realtime'"),
    ("sim_node", ["-p", "publish_rate:=300.0"], "invalid parameter 'publish_rate' = 300", "must divide"),
    ("sim_node", ["-p", "robot_radius:=0.1"], "invalid parameter 'robot_radius' = 0.1", ">= wheel_separation/2"),
    ("sim_node", ["-p", "current_limit:=0.0"], "invalid parameter 'current_limit' = 0.0", "(0, 1000] A"),
    ("sim_node", ["-p", "imu.gyro_noise_std:=-1.0"], "'imu.gyro_noise_std' = -1.0", "[0, 10] rad/s"),
    ("sim_node", ["-p", "scenario:=nowhere"], "invalid parameter 'scenario' = 'nowhere'", "dynamic_obstacles"),
    ("sim_node", ["-p", "use_sim_time:=true"], "'use_sim_time' = True", "sim_node is the clock"),
    ("world_node", ["-p", "robot_radius:=0.0"], "invalid parameter 'robot_radius' = 0.0", "(0, 10] m"),
    ("world_node", ["-p", "rate:=0.0"], "invalid parameter 'rate' = 0.0", "[0.1, 1000] Hz"),
    ("world_node", ["-p", "seed:=lucky"], "invalid parameter 'seed' = 'lucky'", "[-1, 2147483647]"),
    ("command_player", ["-p", "rate:=0.5"], "invalid parameter 'rate' = 0.5", "[1, 1000] Hz"),
]
NODE_PARAMS = {"sim_node": SIM_PARAMS, "world_node": ("world.yaml",), "command_player": ("command_player.yaml",)}


@pytest.mark.parametrize(("node", "args", "names", "valid"), BAD_STARTS)
def test_bad_parameters_stop_the_node_with_one_clear_message(launch, node, args, names, valid):
    assert_refused_at_start(launch("twbr_sim", node, *args, params=NODE_PARAMS[node]), names, valid)


def test_malformed_scenario_file_stops_the_node_naming_the_field(launch, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("duration: 10\nobstacles:\n  - {position: [1, 2], radius: -1.5}\n")
    for node, params in (("sim_node", SIM_PARAMS), ("world_node", ("world.yaml",))):
        proc = launch("twbr_sim", node, "-p", f"scenario:={bad}", params=params)
        assert proc.wait(timeout=30) == 2
        assert "'obstacles[0].radius' = -1.5: must be (0, 1000] m" in proc.stderr
        assert "Traceback" not in proc.output


def test_a_by_hand_scenario_ends_at_its_own_duration(launch, tmp_path):
    """`sim_node -p scenario:=<path>` with sim.yaml's parameters: the scenario's duration applies (before:
    sim.yaml's duration 0 won and the node ran forever); an explicit -p duration still wins."""
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\ndescription: the robot alone for 1.5 s\nduration: 1.5\nseed: 1\n"
                        "robot: {x: 0.0, y: 0.0, yaw: 0.0}\nobstacles: []\n")
    alone = ("-p", f"scenario:={scenario}", "-p", "mode:=realtime", "-p", "real_time_factor:=5.0")  # no controller
    own = launch("twbr_sim", "sim_node", *alone, params=("robot.yaml", "sim.yaml"))
    assert own.wait(timeout=60) == 0, own.output
    assert "stopped at t = 1.500 s" in own.output, own.output[-1500:]
    explicit = launch("twbr_sim", "sim_node", *alone, "-p", "duration:=0.5", params=("robot.yaml", "sim.yaml"))
    assert explicit.wait(timeout=60) == 0, explicit.output
    assert "stopped at t = 0.500 s" in explicit.output, explicit.output[-1500:]
