"""The controller node and the scenario runner as real processes: step responses from the recorded bag,
stale and bad cmd_vel, falls, the enable service, bad parameters, Ctrl-C."""

from __future__ import annotations

import json
import math
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest
from conftest import CONFIG, PATIENT_LOCKSTEP, RUNNER, assert_refused_at_start, recorded_file
from geometry_msgs.msg import Twist, TwistStamped
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import SetBool

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.param_files import node_parameters
from twbr_msgs.msg import ControllerState, SimStatus
from twbr_runner.bag_reader import bag_info, read_messages
from twbr_runner.spawn import NodeProcess

pytestmark = pytest.mark.e2e

RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
SIM_PARAMS = ("robot.yaml", "sim.yaml")
TORQUE_LIMIT = 15.0


def run_scenario(tmp_path, domain: int, *args: str, timeout: float = 240.0) -> subprocess.CompletedProcess:
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    return subprocess.run(
        [*RUNNER, *args, "--out", str(tmp_path), "--domain", str(domain)],
        env=env, capture_output=True, text=True, timeout=timeout,
    )


def only_run_dir(tmp_path):
    dirs = [d for d in tmp_path.iterdir() if d.is_dir()]
    assert len(dirs) == 1, dirs
    return dirs[0]


def test_step_scenario_through_the_runner_meets_the_paper_from_the_bag(tmp_path, ros_domain):
    done = run_scenario(tmp_path, ros_domain, "step")
    assert done.returncode == 0, done.stdout + done.stderr
    run = only_run_dir(tmp_path)
    metrics = json.loads((run / "metrics.json").read_text())
    for png in ("response.png", "velocity.png", "yaw_rate.png", "pitch.png", "wheel_torques.png"):
        assert (run / png).stat().st_size > 10_000, png

    # The bag, read with the mcap libraries (it was written with rosbags), holds every topic of the run.
    info = bag_info(run / "bag")
    assert info["storage_identifier"] == "mcap" and info["version"] == 9
    messages = read_messages(run / "bag")
    for topic in ("/clock", "/tf", "/odom", "/imu", "/joint_states", "/wheel_torque_cmd", "/controller_state",
                  "/cmd_vel", "/sim_status"):
        assert messages.get(topic), topic
    # Lockstep: one state and one command per 5 ms of the 6 s, none lost on the way to the recorder.
    stamps = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in messages["/wheel_torque_cmd"]}
    assert len(stamps) == 1201
    assert metrics["lockstep_timeouts"] == 0

    # The metrics file says what the bag says, read here without the metrics module.
    def stamp(m) -> float:
        return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9

    control = [m for _, m in messages["/controller_state"]]
    odom = [m for _, m in messages["/odom"]]
    assert metrics["sim_time_s"] == pytest.approx(max(stamp(m) for m in control + odom), abs=1e-9)
    assert metrics["max_torque_nm"] == pytest.approx(
        max(max(abs(m.left_torque), abs(m.right_torque)) for m in control), abs=1e-12)
    q = [m.pose.pose.orientation for m in odom]
    pitches = [rpy_from_quaternion(o.x, o.y, o.z, o.w)[1] for o in q]
    assert metrics["pitch_max_rad"] == pytest.approx(max(pitches), abs=1e-9)
    assert metrics["pitch_min_rad"] == pytest.approx(min(pitches), abs=1e-9)
    for key in ("scenario", "seed", "sim_time_s", "wall_time_s", "real_time_factor", "fallen", "pitch_min_rad",
                "pitch_max_rad", "pitch_settle_time_s", "v_rmse", "w_rmse", "max_torque_nm", "lockstep_timeouts"):
        assert key in metrics, key

    # The paper's Figure 6, as the issue states it.
    step = metrics["velocity_step"]
    assert metrics["sim_time_s"] == pytest.approx(6.0) and not metrics["fallen"]
    assert step["final"] == pytest.approx(0.1) and 1.0 <= step["step_time_s"] <= 1.03
    assert step["undershoot"] > 0.005  # rolls back first
    assert step["settle_time_s"] <= 1.5 and step["overshoot_pct"] < 20.0 and step["steady_state_error_pct"] < 2.0
    # A CI run once settled at 4.54 s (1.95 s here, idle or loaded): say whether cmd_vel went stale meanwhile
    assert abs(metrics["pitch_final_rad"]) < 0.005 and metrics["pitch_settle_time_s"] < 4.0, {
        k: metrics.get(k) for k in ("pitch_final_rad", "pitch_settle_time_s", "cmd_vel_stale_samples",
                                    "lockstep_timeouts", "real_time_factor")}
    assert metrics["max_torque_nm"] < TORQUE_LIMIT and metrics["max_delivered_torque_nm"] < TORQUE_LIMIT
    assert "step" in done.stdout and "settles" in done.stdout


def test_yaw_rate_step_through_the_runner(tmp_path, ros_domain):
    done = run_scenario(tmp_path, ros_domain, "yaw_step", "--no-figures")
    assert done.returncode == 0, done.stdout + done.stderr
    metrics = json.loads((only_run_dir(tmp_path) / "metrics.json").read_text())
    yaw = metrics["yaw_rate_step"]
    assert yaw["final"] == pytest.approx(0.5)
    assert yaw["settle_time_s"] <= 1.5 and yaw["steady_state_error_pct"] < 2.0
    assert not metrics["fallen"] and metrics["lockstep_timeouts"] == 0
    assert metrics["velocity_step"]["settle_time_s"] <= 1.5  # the forward step while turning


def test_step_with_realistic_sensors_the_controller_estimates_pitch(tmp_path, ros_domain):
    """The runner's --sensors realistic: the simulator's imu has no orientation, noise, bias and 5 ms delay, its
    odometry comes from 1024-count encoders; the controller estimates pitch and keeps the robot up, and the
    bag keeps the truth beside what the sensors said."""
    done = run_scenario(tmp_path, ros_domain, "step", "--sensors", "realistic", "--no-figures")
    run = only_run_dir(tmp_path)
    messages = read_messages(run / "bag")
    metrics = json.loads((run / "metrics.json").read_text())
    assert not metrics["fallen"], done.stdout + done.stderr
    imu = [m for _, m in messages["/imu"]]
    assert all(m.orientation_covariance[0] == -1.0 for m in imu)
    state = [m for _, m in messages["/controller_state"]]
    assert all(m.pitch_estimated for m in state)
    truth = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec: m for _, m in messages["/ground_truth"]}
    errors = []
    for m in state:
        true = truth[m.header.stamp.sec * 10**9 + m.header.stamp.nanosec].pose.pose.orientation
        errors.append(m.pitch - rpy_from_quaternion(true.x, true.y, true.z, true.w)[1])
    rms = float(np.sqrt(np.mean(np.square(errors))))
    assert rms < 0.02  # 5 mg of accelerometer bias alone is 5 mrad
    # odom is dead reckoning from counts: its speed moves in half counts (two wheels) per 20 ms window
    speeds = np.array([m.twist.twist.linear.x for _, m in messages["/odom"]])[4:]  # once the window is full
    quantum = 2 * np.pi / 1024 * 0.1 / 0.02 / 2  # the mean of two wheels
    assert np.allclose(speeds / quantum, np.round(speeds / quantum), atol=1e-6)
    status = messages["/sim_status"][-1][1]
    assert status.lift_events == 0 and status.normal_force_left > 0.0
    # The paper's response, from the true speed (ground_truth) in the bag: the estimator calibrates for 0.5 s on
    # the stand, then the step at 1 s settles as the issue asks.
    step = metrics["velocity_step"]
    assert step["settle_time_s"] <= 1.5 and step["steady_state_error_pct"] < 2.0
    assert step["undershoot"] <= 0.5 * 0.1 + 0.01
    assert metrics["pitch_estimate_rms_error_rad"] < 0.02 and metrics["wheel_lift_events"] == 0


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_stopped_runner_stops_every_process_and_keeps_a_readable_bag(tmp_path, ros_domain, signum):
    env = {**os.environ, "ROS_DOMAIN_ID": str(ros_domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    proc = subprocess.Popen(
        [*RUNNER, "dynamic_obstacles", "--out", str(tmp_path), "--domain",
         str(ros_domain), "--no-figures"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(tmp_path.glob("*/logs/sim.err")):
        time.sleep(0.2)
    run = only_run_dir(tmp_path)
    # Mid-run: the recorder has written a few seconds of sim time (~0.4 MB each), out of the 70 s this
    # scenario takes to reach its target; a fixed wall-clock wait assumed a machine's speed.
    mcap = recorded_file(run / "bag", "*.mcap", 2_000_000, 60, running=lambda: proc.poll() is None)
    if proc.poll() is not None:
        pytest.fail(f"the runner ended by itself ({proc.returncode}) before it was stopped:\n{proc.communicate()[0]}")
    assert mcap is not None, "the recorder wrote under 2 MB to disk in 60 s"
    proc.send_signal(signum)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, out
    assert f"interrupted by {signal.Signals(signum).name}" in out
    # No process of the run is left: the command lines name the run's bag or parameter files.
    leftover = subprocess.run(["pgrep", "-f", str(tmp_path)], capture_output=True, text=True).stdout.split()
    assert leftover == []
    info = bag_info(run / "bag")  # closed cleanly: metadata written
    assert info["message_count"] > 0
    assert read_messages(run / "bag", ["/odom"])["/odom"]


class ControllerHarness:
    """sim_node (robot alone) + controller_node as processes; the test plays cmd_vel and watches."""

    def __init__(self, launch, ros, *controller_args: str, stamped: bool = False, sim_args: tuple = ()) -> None:
        self.states: list[ControllerState] = []
        self.status: list[SimStatus] = []
        ros.node.create_subscription(ControllerState, "controller_state", self.states.append, RELIABLE)
        ros.node.create_subscription(SimStatus, "sim_status", self.status.append, RELIABLE)
        self.pub = ros.node.create_publisher(TwistStamped if stamped else Twist, "cmd_vel", RELIABLE)
        self.controller = launch("twbr_control", "controller_node", *controller_args,
                                 *(["-p", "enable_stamped_cmd_vel:=true"] if stamped else []),
                                 params=("controller.yaml",))
        self.sim = launch("twbr_sim", "sim_node", "-p", "wait_for_subscribers:=1", *sim_args, params=SIM_PARAMS)
        self.ros = ros
        assert ros.spin_until(lambda: len(self.states) > 20, 30.0), self.controller.output + self.sim.output

    def sim_time(self) -> float:
        s = self.states[-1].header.stamp
        return s.sec + s.nanosec * 1e-9

    def run_until(self, t: float, every=None, timeout: float = 60.0) -> None:
        def done() -> bool:
            if every is not None:
                every()
            return self.sim_time() >= t

        assert self.ros.spin_until(done, timeout)


def test_stale_cmd_vel_zeroes_the_references_and_the_robot_balances_in_place(launch, ros):
    # Real time, as a robot runs: in lockstep the graph outran this test's publications on a loaded host
    # (more than cmd_vel_timeout of sim time between two), so the command went stale before it stopped.
    h = ControllerHarness(launch, ros, sim_args=("-p", "mode:=realtime"))
    fwd = Twist()
    fwd.linear.x = 0.3
    h.run_until(3.0, every=lambda: h.pub.publish(fwd))
    assert h.states[-1].velocity_ref == pytest.approx(0.3) and not h.states[-1].cmd_vel_stale
    moving = h.states[-1].velocity
    assert moving == pytest.approx(0.3, abs=0.03)
    silent_from = h.sim_time()
    h.run_until(silent_from + 4.0)  # nobody publishes cmd_vel any more
    stale = [s for s in h.states if s.cmd_vel_stale]
    first = stale[0].header.stamp.sec + stale[0].header.stamp.nanosec * 1e-9
    assert first - silent_from <= 0.5 + 0.1  # cmd_vel_timeout, give or take the last publications
    assert all(s.velocity_ref == 0.0 and s.yaw_rate_ref == 0.0 for s in stale)
    assert abs(h.states[-1].velocity) < 0.01  # stopped ...
    assert abs(h.states[-1].pitch) < 0.01 and not any(s.fallen for s in h.status)  # ... and balancing


def test_nan_cmd_vel_never_reaches_the_motors_and_stamped_cmd_vel_works(launch, ros):
    # Real time, as a robot runs: this test stamps its commands with the newest state it has seen, and in
    # lockstep on a loaded host it saw states more than cmd_vel_timeout (0.5 s) of sim time late, so the
    # controller rightly dropped even the good ones as stale.
    h = ControllerHarness(launch, ros, stamped=True, sim_args=("-p", "mode:=realtime"))
    good, bad = TwistStamped(), TwistStamped()
    good.twist.angular.z = 0.5
    bad.twist.linear.x = math.nan

    def publish_both() -> None:
        for msg in (good, bad):
            msg.header.stamp = h.states[-1].header.stamp
            h.pub.publish(msg)

    h.run_until(3.0, every=publish_both)
    last = h.states[-1]
    assert last.yaw_rate_ref == pytest.approx(0.5) and last.velocity_ref == 0.0
    assert all(math.isfinite(s.left_torque) and math.isfinite(s.right_torque) for s in h.states)
    assert last.yaw_rate == pytest.approx(0.5, abs=0.03)
    assert "dropped cmd_vel: non-finite value" in h.controller.output


def test_fall_cuts_the_torque_and_enable_restarts_the_loops(launch, ros, tmp_path):
    tilted = tmp_path / "tilted.yaml"
    tilted.write_text("name: tilted\nduration: 30\nrobot: {pitch: 0.4}\n")  # past fall_pitch 0.3
    h = ControllerHarness(launch, ros, "-p", "fall_pitch:=0.3", sim_args=("-p", f"scenario:={tilted}"))
    h.run_until(0.5)
    falls = [s for s in h.states if s.fallen]
    assert falls and all(s.left_torque == 0.0 == s.right_torque for s in falls)
    assert "fallen: |pitch|" in h.controller.output
    client = ros.node.create_client(SetBool, "/controller_node/enable")
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(SetBool.Request(data=True))
    assert ros.spin_until(future.done, 10.0) and future.result().success
    # The simulated robot lies on the floor (|pitch| > fall_pitch): the controller falls again at once,
    # from fresh loops, and never drives the wheels of a fallen robot.
    n = len(h.states)
    h.run_until(h.sim_time() + 0.5)
    assert all(s.fallen and s.left_torque == 0.0 for s in h.states[n + 1:])


BAD_STARTS = [
    (["-p", "velocity.kp:=-1.0"], "invalid parameter 'velocity.kp' = -1.0", "[0, 100] rad·s/m"),
    (["-p", "rate:=0.0"], "invalid parameter 'rate' = 0.0", "[1, 2000] Hz"),
    (["-p", "max_wheel_torque:=0.0"], "invalid parameter 'max_wheel_torque' = 0.0", "(0, 1000] N·m"),
    (["-p", "velocity.setpoint_weight:=1.5"], "'velocity.setpoint_weight' = 1.5", "[0, 1]"),
    (["-p", "cmd_vel_timeout:=fast"], "invalid parameter 'cmd_vel_timeout' = 'fast'", "[0.01, 60] s"),
    (["-p", "fall_pitch:=0.1"], "invalid parameter 'max_pitch_ref' = 0.15", "below fall_pitch"),  # inconsistent
    (["-p", "cpu_affinity:=[4096]"], "invalid parameter 'cpu_affinity' = [4096]", "CPUs this process may use"),
    (["-p", "cpu_affinity:=1"], "invalid parameter 'cpu_affinity' = 1", "a list of integers in [0, inf)"),
    (["-p", "realtime_priority:=100"], "invalid parameter 'realtime_priority' = 100", "[0, 99]"),
]


@pytest.mark.parametrize(("args", "names", "valid"), BAD_STARTS)
def test_bad_controller_parameters_stop_the_node_with_one_clear_message(launch, args, names, valid):
    assert_refused_at_start(launch("twbr_control", "controller_node", *args, params=("controller.yaml",)),
                            names, valid)


def test_cpu_affinity_pins_every_thread_of_the_node(launch, ros):
    cpu = max(os.sched_getaffinity(0))
    proc = launch("twbr_control", "controller_node", "-p", f"cpu_affinity:=[{cpu}]", params=("controller.yaml",))
    assert ros.spin_until(lambda: f"pinned to CPU {cpu}" in proc.output or not proc.running, 30.0), proc.output
    tasks = Path(f"/proc/{proc.proc.pid}/task")
    affinities = {tid.name: os.sched_getaffinity(int(tid.name)) for tid in tasks.iterdir()}
    assert len(affinities) > 3  # DDS's threads, started before the parameter was read, are there too
    assert all(cpus == {cpu} for cpus in affinities.values()), affinities


@pytest.mark.skipif(os.geteuid() != 0 and resource.getrlimit(resource.RLIMIT_RTPRIO)[0] < 10,
                    reason="SCHED_FIFO needs root or an rtprio limit of 10 (ulimit -r) here")
def test_realtime_priority_puts_every_thread_of_the_node_under_fifo(launch, ros):
    proc = launch("twbr_control", "controller_node", "-p", "realtime_priority:=10", params=("controller.yaml",))
    assert ros.spin_until(lambda: "realtime priority 10 (SCHED_FIFO)" in proc.output or not proc.running, 30.0), \
        proc.output
    tids = [int(tid.name) for tid in Path(f"/proc/{proc.proc.pid}/task").iterdir()]
    assert len(tids) > 3  # DDS's threads, started before the parameter was read, are there too
    assert {(os.sched_getscheduler(t), os.sched_getparam(t).sched_priority) for t in tids} == {(os.SCHED_FIFO, 10)}


def test_runner_refuses_an_unknown_scenario(tmp_path, ros_domain):
    done = run_scenario(tmp_path, ros_domain, "nowhere")
    assert done.returncode == 2
    assert "invalid parameter 'scenario' = 'nowhere'" in done.stderr and "step" in done.stderr


def test_shipped_controller_file_matches_the_parameter_table():

    from twbr_common.guard import INPUT_SPECS
    from twbr_common.params import validate_all
    from twbr_control.controller_params import CONTROL_SPECS, NODE_SPECS

    params = node_parameters(CONFIG / "controller.yaml", "controller_node")
    known = {s.name for s in (*CONTROL_SPECS, *NODE_SPECS, *INPUT_SPECS)} | {"use_sim_time"}
    assert set(params) <= known
    validate_all(CONTROL_SPECS, {k: v for k, v in params.items() if k in {s.name for s in CONTROL_SPECS}})
    assert np.isclose(params["rate"], 200.0)


def test_controller_follows_a_realtime_simulator_on_the_wall_clock(launch, ros):
    """Realtime mode: the simulator steps on a wall timer like a robot; the controller keeps up at 200 Hz."""
    h = ControllerHarness(launch, ros, sim_args=("-p", "mode:=realtime"))
    fwd = Twist()
    fwd.linear.x = 0.2
    wall0, sim0 = time.monotonic(), h.sim_time()
    h.run_until(sim0 + 3.0, every=lambda: h.pub.publish(fwd), timeout=20.0)
    wall = time.monotonic() - wall0
    # Sim time follows the wall clock: never faster (a realtime simulator paces itself), and on a loaded
    # host not much slower either (this test's own view of it lags by up to a few hundred ms).
    assert 0.5 <= 3.0 / wall <= 1.1, wall
    recent = [s for s in h.states if s.header.stamp.sec + s.header.stamp.nanosec * 1e-9 > sim0 + 1.5]
    dts = np.array([s.dt for s in recent])
    assert np.median(dts) == pytest.approx(0.005, abs=1e-6)  # one command per 5 ms state
    assert recent[-1].velocity == pytest.approx(0.2, abs=0.02)
    assert not any(s.fallen for s in h.status)


@pytest.mark.parametrize(("package", "name", "params", "ready", "compiled", "max_mib"), [
    # what a robot's computer runs at 200 Hz: interpreted, no numba or LLVM loaded (TWBR_JIT defaults to off)
    ("twbr_control", "controller_node", "controller.yaml", "cascaded PID (speed -> pitch -> torque", False, 100.0),
    # compiled by default since issue 35 (the robust method's yielding is 88 ms p99 interpreted): 254 MiB
    # resident measured in CI with every method's kernels loaded
    ("twbr_planner", "planner_node", "planner.yaml", "planning at 20 Hz with the robust potential field", True,
     300.0),
])
def test_the_deployable_nodes_start_as_documented_and_stay_small(launch, package, name, params, ready, compiled,
                                                                  max_mib):
    node = launch(package, name, params=(params,))
    deadline = time.monotonic() + 60.0
    while ready not in node.output:
        assert node.running and time.monotonic() < deadline, node.output
        time.sleep(0.1)
    maps = Path(f"/proc/{node.proc.pid}/maps").read_text()
    assert ("llvmlite" in maps and "numba" in maps) == compiled
    rss_mib = psutil.Process(node.proc.pid).memory_info().rss / 2**20
    assert rss_mib <= max_mib, f"{name}: {rss_mib:.0f} MiB resident"


LATE_PLAYER = """
import sys, time
import rclpy
from geometry_msgs.msg import Twist
from rosgraph_msgs.msg import Clock
rclpy.init()
node = rclpy.create_node("late_player")
pub = node.create_publisher(Twist, "cmd_vel", 10)
last = [None]
def tick(m):
    t = m.clock.sec + m.clock.nanosec * 1e-9
    v = 0.1 if t >= 1.0 else 0.0  # the profile of config/scenarios/step.yaml
    if v != last[0]:
        if last[0] is not None:
            time.sleep(0.3)  # starved: the step goes out 0.3 s (wall) after its /clock
        last[0] = v
    msg = Twist()
    msg.linear.x = v
    pub.publish(msg)
node.create_subscription(Clock, "/clock", tick, 10)
rclpy.spin(node)
"""


@pytest.mark.parametrize("wait", [True, False], ids=["waited_for", "before"])
def test_a_player_late_with_its_profiles_step_still_steps_the_robot_on_time(launch, ros, ros_env, tmp_path, wait):
    """A scripted profile's player starved on a loaded host (here it sends the 0.1 m/s step 0.3 s of wall time
    after the /clock that called for it). Before (`lockstep_commands` false, the `before` case): the simulator
    ran on with the controller alone and the step reached the controller more than 0.1 s late in sim time, here
    not within the 2 s run (CI saw 1.1 and 1.22 s for 1.0 s); now the state of the change waits for it.

    What the simulator waits for is its own copy of the Twist: the controller hears the same sample on its own
    subscription and applies it from the first state after its arrival, so a player preempted between its two
    deliveries still lets the controller apply the step a few states late (CI saw 1.015 s: three states). The
    bound here, 10 states (0.05 s), is that race's; the player's own lateness, 0.3 s of wall time, is waited
    out."""
    player = NodeProcess([sys.executable, "-c", LATE_PLAYER], ros_env, tmp_path, "late_player")
    refs: list[tuple[float, float]] = []
    ros.node.create_subscription(ControllerState, "controller_state",
                                 lambda m: refs.append((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                                                        m.velocity_ref)), RELIABLE)
    try:
        launch("twbr_control", "controller_node", params=("controller.yaml",))
        assert ros.spin_until(lambda: ros.node.count_subscribers("/clock") >= 2, 30.0), player.output
        sim = launch("twbr_sim", "sim_node", "-p", "scenario:=step", "-p", "duration:=2.0",
                     "-p", f"lockstep_commands:={str(wait).lower()}", "-p", "wait_for_subscribers:=1",
                     *PATIENT_LOCKSTEP, params=SIM_PARAMS)
        assert ros.spin_until(lambda: not sim.running, 120.0), sim.output
        ros.spin_for(0.5)
    finally:
        player.stop()
    stepped = [t for t, v in refs if v == pytest.approx(0.1)]
    assert refs and refs[-1][0] >= 1.9, refs[-3:]  # the whole run, 2 s
    if wait:
        assert stepped and 1.0 <= stepped[0] <= 1.05, stepped[:1]
        assert "lockstep timeout at" not in sim.output and ", 0 lockstep timeouts;" in sim.output, sim.output
    else:
        assert not stepped or stepped[0] > 1.1, stepped[0]  # late, or not within the run at all
