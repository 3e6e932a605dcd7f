"""Tools that lose nothing and leave nothing behind, through the real processes: a runner killed with
SIGKILL, a recorder killed with SIGKILL (a power cut) whose bag is recovered, and one held back mid-run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import psutil
import pytest
from conftest import RUNNER, recorded_file
from rosgraph_msgs.msg import Clock

from twbr_runner.bag_reader import BagError, bag_info, read_messages
from twbr_runner.spawn import NodeProcess, node_executable

pytestmark = pytest.mark.e2e
HERE = Path(__file__).parent
COURSE = HERE / "scenarios" / "fault_course.yaml"


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"


def test_a_runner_killed_with_sigkill_leaves_no_node_behind_and_a_closed_bag(tmp_path, ros_env):
    # Before: the recorder, controller and planner kept running under PID 1 with the bag open.
    runner = subprocess.Popen([sys.executable, "-m", "twbr_runner.runner", str(COURSE), "--out", str(tmp_path),
                               "--quiet", "--no-figures"], env=ros_env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        driving = recorded_file(tmp_path, "*/bag/*.mcap", 2_000_000, 90)  # driving, not just started
        assert driving is not None, "the recorder wrote under 2 MB in 90 s"
        nodes = _children(runner.pid)
    finally:
        runner.kill()  # also when the wait above fails: its nodes go with it
        runner.wait()
    assert len(nodes) == 4, nodes  # recorder, controller, planner, simulator
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and any(_alive(p) for p in nodes):
        time.sleep(0.1)
    assert not any(_alive(p) for p in nodes), [p for p in nodes if _alive(p)]
    (run_dir,) = tmp_path.iterdir()
    info = bag_info(run_dir / "bag")  # the recorder closed it on its way out
    assert info["message_count"] > 100


# long (make test-long), not in make test: it fails now and then even alone (fresh-clone CI at a55f5a0:
# /wheel_torque_cmd 1200 of 1201), and beside another worker's step run (1 in 3 paired runs at 0936424):
# the held-back recorder's catch-up is not yet reliable; to be mended, then put back.
@pytest.mark.alone
@pytest.mark.long
def test_a_recorder_held_back_mid_run_still_records_every_step_of_it(tmp_path, ros, ros_env):
    """The runner's recorder is niced: on a loaded machine it can wait for the CPU while the lockstep loop runs
    on. It catches up from the publishers' history; before, the commands' history of 10 lost them (CI: 1199
    of 1201 wheel torque commands in a bag)."""
    runner = subprocess.Popen([*RUNNER, "step", "--no-figures", "--quiet", "--out", str(tmp_path)], env=ros_env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    clock: list[float] = []
    ros.node.create_subscription(Clock, "/clock", lambda m: clock.append(m.clock.sec + m.clock.nanosec * 1e-9), 10)
    try:
        assert ros.spin_until(lambda: clock and clock[-1] >= 1.0, 120.0), "the run did not start"
        (recorder,) = [p for p in psutil.Process(runner.pid).children(recursive=True)
                       if "recorder" in " ".join(p.cmdline())]
        before = clock[-1]
        recorder.suspend()
        try:
            ros.spin_for(0.5)
        finally:  # a stopped recorder would not act on the SIGTERM its runner's end sends it
            recorder.resume()
        held_back_s = clock[-1] - before
        out, _ = runner.communicate(timeout=120)
    finally:
        if runner.poll() is None:
            runner.kill()
            runner.wait()
    assert runner.returncode == 0, out
    assert held_back_s >= 0.5, held_back_s  # sim time the loop ran on without the recorder: 100 steps or more
    (run_dir,) = tmp_path.iterdir()
    messages = read_messages(run_dir / "bag")
    for topic in ("/wheel_torque_cmd", "/controller_state", "/odom", "/imu", "/joint_states"):
        stamps = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in messages[topic]}
        assert len(stamps) == 1201, (topic, len(stamps))  # one per 5 ms step of the 6 s, from t = 0


def test_a_recorder_killed_with_sigkill_leaves_a_bag_that_recover_bag_makes_readable(tmp_path, launch, ros_env):
    # Before: every reader refused the bag, although the messages flushed before the cut were in the file.
    bag = tmp_path / "bag"
    argv = [str(node_executable("twbr_runner", "recorder")), "-o", str(bag), "-a", "odom:nav_msgs/msg/Odometry"]
    recorder = NodeProcess(argv, ros_env, tmp_path, "recorder")
    try:
        launch("twbr_sim", "sim_node", "-p", "mode:=realtime", "-p", "wait_for_subscribers:=1",
               params=("robot.yaml", "sim.yaml"))
        mcap = recorded_file(bag, "*.mcap", 3_000_000, 60)  # a few chunks on disk
        assert mcap is not None, recorder.output
        os.kill(recorder.proc.pid, signal.SIGKILL)
        recorder.wait(timeout=5)
        with pytest.raises(BagError):
            bag_info(bag)
        done = subprocess.run([str(node_executable("twbr_runner", "recover_bag")), str(bag)], env=ros_env,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stdout + done.stderr
        info = bag_info(bag)
        odom = read_messages(bag, ["/odom"])["/odom"]
        assert info["message_count"] >= len(odom) > 1000  # -a records the other topics too
        stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for _, m in odom]
        assert stamps == sorted(stamps) and stamps[1] - stamps[0] == pytest.approx(0.005, abs=1e-9)
        print(done.stdout.strip())
    finally:
        recorder.stop(timeout=10)  # a no-op once killed


def test_the_recorder_reports_what_it_has_matched_on_a_latched_status_topic(tmp_path, ros, ros_env):
    # What a runner waits for before it starts the clock, read from the graph instead of the recorder's log.
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    from twbr_msgs.msg import RecorderStatus

    bag = tmp_path / "bag"
    argv = [str(node_executable("twbr_runner", "recorder")), "-o", str(bag), "-a", "odom:nav_msgs/msg/Odometry",
            "chatter:std_msgs/msg/String"]
    recorder = NodeProcess(argv, ros_env, tmp_path, "recorder")
    try:
        reports: list[RecorderStatus] = []
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        ros.node.create_subscription(RecorderStatus, "/recorder/status", reports.append, latched)
        assert ros.spin_until(lambda: reports, 30.0), recorder.output  # ready: the first report
        first = reports[-1]
        assert list(first.topics) == ["/chatter", "/odom"] and list(first.matched_publishers) == [0, 0]
        assert first.bag == str(bag)
        pub = ros.node.create_publisher(String, "chatter", 10)

        def matched(topic: str) -> int:
            last = reports[-1]
            return dict(zip(last.topics, last.matched_publishers, strict=True)).get(topic, -1)

        assert ros.spin_until(lambda: matched("/chatter") == 1 and matched("/odom") == 0, 30.0), recorder.output
        ros.node.destroy_publisher(pub)
        assert ros.spin_until(lambda: matched("/chatter") == 0, 30.0), recorder.output
        ros.spin_for(0.5)  # -a: the recorder has looked at the graph many times (every 50 ms)
        assert "/recorder/status" not in [t for r in reports for t in r.topics]  # its own status is not recorded
    finally:
        recorder.stop(timeout=10)


def test_the_recorder_keeps_every_message_acknowledged_before_sigint_and_serves_its_parameters(
        tmp_path, ros, ros_env):
    # It takes its messages in batches: what arrived since the last batch must still reach the bag when
    # SIGINT comes, in the order sent; and its services answer between batches, as any node's do.
    from rcl_interfaces.srv import GetParameters
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    bag = tmp_path / "bag"
    # Batches a minute apart: the first at start, the next long after SIGINT; these messages are waiting.
    argv = [str(node_executable("twbr_runner", "recorder")), "-o", str(bag), "--drain-period", "60",
            "chatter:std_msgs/msg/String"]
    recorder = NodeProcess(argv, ros_env, tmp_path, "recorder")
    try:
        pub = ros.node.create_publisher(String, "chatter", QoSProfile(depth=1000,
                                                                       reliability=ReliabilityPolicy.RELIABLE))
        assert ros.spin_until(lambda: pub.get_subscription_count() == 1, 30.0), recorder.output
        client = ros.node.create_client(GetParameters, "/recorder/get_parameters")
        assert client.wait_for_service(timeout_sec=10.0), recorder.output
        future = client.call_async(GetParameters.Request(names=["use_sim_time"]))
        assert ros.spin_until(future.done, 10.0), recorder.output
        assert future.result().values[0].bool_value is False
        for i in range(600):
            pub.publish(String(data=str(i)))
        assert pub.wait_for_all_acked(Duration(seconds=30))  # in the recorder's queue (~2 s: heartbeats)
        recorder.interrupt()  # at once: these are still waiting for the next batch
        assert recorder.proc.wait(timeout=10) == 0, recorder.output
    finally:
        recorder.stop(timeout=10)
    stamps, texts = zip(*[(t, m.data) for t, m in read_messages(bag)["/chatter"]], strict=True)
    assert list(texts) == [str(i) for i in range(600)]
    assert list(stamps) == sorted(stamps)


def _flood(ros, topic: str, megabytes_per_s: float, until: Callable[[], bool], timeout: float) -> int:
    """Publish incompressible 256 KB messages on `topic` until `until()`; returns how many were sent."""
    import array

    from std_msgs.msg import UInt8MultiArray

    pub = ros.node.create_publisher(UInt8MultiArray, topic, 10)
    msg = UInt8MultiArray()
    sent = 0
    deadline = time.monotonic() + timeout
    period = 0.25 / megabytes_per_s
    while not until() and time.monotonic() < deadline:
        msg.data = array.array("B", os.urandom(256 * 1024))
        pub.publish(msg)
        sent += 1
        ros.spin_for(period)
    return sent


def test_a_full_disk_stops_the_recorder_in_one_line_and_the_bag_is_recovered_elsewhere(tmp_path, ros, ros_env,
                                                                                     small_disk):
    """Before: a multi-line OSError traceback (its own error file cut at 4 KB on the same full disk), and
    recover_bag onto a full disk was a traceback too."""
    disk = small_disk(8)
    bag = disk / "bag"
    argv = [str(node_executable("twbr_runner", "recorder")), "-o", str(bag), "flood:std_msgs/msg/UInt8MultiArray"]
    recorder = NodeProcess(argv, ros_env, tmp_path, "recorder")
    assert ros.spin_until(lambda: "recording to" in recorder.output, 30.0), recorder.output
    sent = _flood(ros, "flood", 10.0, lambda: not recorder.running, 30.0)
    assert recorder.wait(timeout=10) == 1, recorder.output
    lines = recorder.stderr.strip().splitlines()
    stopped = [line for line in lines if "recording stopped" in line]
    assert len(stopped) == 1 and "Traceback" not in recorder.output, recorder.output[-3000:]
    for piece in (f"cannot write {bag}", "No space left on device", "MB free of", "recover_bag", "-o"):
        assert piece in stopped[0], (piece, stopped[0])
    assert not (bag / "metadata.yaml").exists()

    # Onto the same full disk: one line, nothing half-written left, the source untouched.
    before = sorted((p.name, p.stat().st_size) for p in bag.iterdir())
    again = subprocess.run([str(node_executable("twbr_runner", "recover_bag")), str(bag), "-o", str(disk / "again")],
                           env=ros_env, capture_output=True, text=True, timeout=120)
    assert again.returncode == 1 and "Traceback" not in again.stderr, again.stderr
    assert len(again.stderr.strip().splitlines()) == 1 and "No space left on device" in again.stderr
    assert not (disk / "again").exists() and sorted((p.name, p.stat().st_size) for p in bag.iterdir()) == before
    in_place = subprocess.run([str(node_executable("twbr_runner", "recover_bag")), str(bag)], env=ros_env,
                              capture_output=True, text=True, timeout=120)
    assert in_place.returncode == 1 and "nothing was changed" in in_place.stderr, in_place.stderr
    assert sorted((p.name, p.stat().st_size) for p in bag.iterdir()) == before

    # Elsewhere: a readable bag with what was written before the disk filled.
    fixed = tmp_path / "fixed"
    done = subprocess.run([str(node_executable("twbr_runner", "recover_bag")), str(bag), "-o", str(fixed)],
                          env=ros_env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    flood = read_messages(fixed, ["/flood"])["/flood"]
    assert 15 <= len(flood) <= sent and all(len(m.data) == 256 * 1024 for _, m in flood), (len(flood), sent)
    print(f"{len(flood)} of {sent} messages (256 KB) recovered from a full 8 MB disk")


def test_a_run_whose_disk_fills_fails_in_one_line_pointing_at_recover_bag(tmp_path, ros_env, small_disk):
    disk = small_disk(3)
    done = subprocess.run([sys.executable, "-m", "twbr_runner.runner", str(COURSE), "--out", str(disk), "--quiet",
                           "--no-figures"], env=ros_env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "Traceback" not in done.stderr, done.stderr[-3000:]
    assert "recorder exited with code 1" in done.stderr and "No space left on device" in done.stderr, done.stderr
    (bag,) = disk.glob("*/bag")
    pointer = [line for line in done.stderr.splitlines() if "was not closed" in line]
    assert len(pointer) == 1 and f"recover_bag {bag} -o" in pointer[0], done.stderr
