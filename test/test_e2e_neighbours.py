"""Neighbours on one ROS_DOMAIN_ID, through the real processes: a second graph, a publisher of another type."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from conftest import RUNNER
from geometry_msgs.msg import Twist

from twbr_runner.spawn import NodeProcess, node_executable

pytestmark = pytest.mark.e2e
HERE = Path(__file__).parent
COURSE = HERE / "scenarios" / "fault_course.yaml"


def test_a_second_graph_on_the_same_domain_is_reported_and_the_runner_refuses_to_start(launch, ros, ros_env, tmp_path):
    # Before: the second run deadlocked, and its metrics.json reported the other run's success.
    first = launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", params=("robot.yaml", "sim.yaml"))
    second = launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", params=("robot.yaml", "sim.yaml"))
    def reported(sim, topic: str) -> list[str]:
        return [line for line in sim.output.splitlines() if f"a second publisher on {topic}," in line]

    for sim in (first, second):  # endpoints are discovered topic by topic: each is reported once seen
        for topic in ("/clock", "/odom", "/imu"):
            assert ros.spin_until(lambda s=sim, t=topic: reported(s, t), 20.0), sim.output
            assert "ERROR" in reported(sim, topic)[0]
    done = subprocess.run([*RUNNER, str(COURSE), "--out", str(tmp_path / "runs"),
                           "--quiet", "--no-figures"], env=ros_env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stdout + done.stderr
    refusal = done.stderr.strip().splitlines()
    assert len(refusal) == 1 and "another graph is already on ROS_DOMAIN_ID" in refusal[0], done.stderr
    assert "node /sim_node" in refusal[0] and "publishing /clock" in refusal[0]
    assert not (tmp_path / "runs").exists()  # nothing started, nothing written


def test_a_publisher_of_another_type_is_reported_and_the_bag_keeps_the_contracts_type(launch, ros, ros_env, tmp_path):
    # Before: a std_msgs/String on /cmd_vel made the bag record /cmd_vel as String and lose every Twist.
    # Another process: one DDS participant cannot hold two types on one topic.
    code = ("import rclpy, time\nfrom std_msgs.msg import String\nrclpy.init()\nn = rclpy.create_node('wrong_type')\n"
            "p = n.create_publisher(String, 'cmd_vel', 10)\nwhile True:\n    p.publish(String(data='go'))\n"
            "    time.sleep(0.05)\n")
    wrong = NodeProcess([sys.executable, "-c", code], ros_env, tmp_path, "wrong_type")
    try:
        _check_wrong_type_reported(launch, ros, ros_env, tmp_path)
    finally:
        wrong.stop()


def _check_wrong_type_reported(launch, ros, ros_env, tmp_path) -> None:
    right = ros.node.create_publisher(Twist, "cmd_vel", 10)
    assert ros.spin_until(lambda: len(ros.node.get_publishers_info_by_topic("/cmd_vel")) == 2, 20.0)
    bag = tmp_path / "bag"
    argv = [str(node_executable("twbr_runner", "recorder")), "-o", str(bag), "-a", "cmd_vel:geometry_msgs/msg/Twist"]
    recorder = NodeProcess(argv, ros_env, tmp_path, "recorder")
    try:
        # Our Twist publisher matched first: the planner (up in ~0.5 s) would otherwise be matched with it.
        assert ros.spin_until(lambda: "matched 1 publisher(s) on /cmd_vel" in recorder.output, 20.0), recorder.output
        planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
        for _ in range(20):
            right.publish(Twist())
            ros.spin_for(0.05)
        assert ros.spin_until(lambda: "a publisher of std_msgs/msg/String on /cmd_vel" in planner.output, 10.0)
        assert ros.spin_until(lambda: "not recorded: /wrong_type [std_msgs/msg/String]" in recorder.output, 10.0), \
            recorder.output
        assert recorder.stop(timeout=10) == 0
        info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
        assert topics["/cmd_vel"]["topic_metadata"]["type"] == "geometry_msgs/msg/Twist"
        assert topics["/cmd_vel"]["message_count"] >= 20  # every Twist (and the planner's, if it planned)
    finally:
        recorder.stop(timeout=10)


@pytest.mark.parametrize("apart", [0.0, pytest.param(0.5, marks=pytest.mark.long)])  # 0.5 s: make test-long
def test_two_runners_started_together_never_both_measure_a_mixed_graph(ros_env, tmp_path, apart):
    """Two runners on one --domain, started together or 0.5 s apart. Before: both ran (real-time factor
    0.09, 168 lockstep timeouts) and both wrote `reached: false` with no word of the conflict. Now the later
    one refuses, naming the earlier runner; where discovery is too slow for that, a run that sees the other
    graph's publishers ends with exit 1 and `foreign_publishers` in its metrics.json."""
    argv = [*RUNNER, str(COURSE), "--quiet", "--no-figures"]
    first = subprocess.Popen([*argv, "--out", str(tmp_path / "a")], env=ros_env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    time.sleep(apart)
    second = subprocess.Popen([*argv, "--out", str(tmp_path / "b")], env=ros_env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    results = []
    for proc, out in ((first, tmp_path / "a"), (second, tmp_path / "b")):
        stdout, stderr = proc.communicate(timeout=300)
        metrics = [json.loads(p.read_text()) for p in out.glob("*/metrics.json")]
        results.append((proc.returncode, stdout + stderr, metrics[0] if metrics else None))
    ran = [r for r in results if r[0] == 0]
    assert len(ran) <= 1, results  # never two "successful" runs of one mixed graph
    for code, output, metrics in results:
        if code == 0:
            assert metrics["reached"] and metrics["foreign_publishers"] == [] and metrics["lockstep_timeouts"] == 0, \
                (metrics, output)
        else:
            assert code == 1, output
            refused = "refusing to start" in output and "runner run_scenario_" in output
            foreign = metrics is not None and metrics["foreign_publishers"] and (
                "another graph joined" in output or "not this run's" in output)
            assert refused or foreign, output  # never a plain failure to reach
    # On loopback each sees the other's runner node within its 1.5 s look: the later one (by the claim its
    # node's name carries, not by which process was spawned first) refuses, and the earlier one runs.
    assert len(ran) == 1, results
    later = next(r for r in results if r[0] == 1)
    assert "refusing to start" in later[1] and "before this one" in later[1] and later[2] is None, later[1]


def test_another_graph_joining_mid_run_ends_the_run_with_exit_1_and_says_so(ros_env, launch, tmp_path):
    """Where discovery was too slow for the start-up check: a second simulator joins the run's domain while
    it runs. The run ends at once, exit 1, with the other graph named in its output and metrics.json."""
    runner = subprocess.Popen([*RUNNER, str(COURSE), "--out",
                               str(tmp_path / "runs"), "--quiet", "--no-figures"], env=ros_env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list((tmp_path / "runs").glob("*/logs/sim.err")):
        time.sleep(0.05)
    time.sleep(1.0)
    other = launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", params=("robot.yaml", "sim.yaml"))
    out, err = runner.communicate(timeout=120)
    assert runner.returncode == 1, out + err
    assert "another graph joined this run's ROS_DOMAIN_ID" in err and "/sim_node publishing /clock" in err, err
    (metrics,) = (tmp_path / "runs").glob("*/metrics.json")
    m = json.loads(metrics.read_text())
    assert any("a second /sim_node publishing" in f for f in m["foreign_publishers"]), m
    assert m["ended_by"].startswith("failed: another graph joined"), m["ended_by"]
    assert other.running  # the other graph is not ours to stop
