"""Neighbours on one ROS_DOMAIN_ID, through the real processes: a second graph, a publisher of another type."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml
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
    done = subprocess.run([sys.executable, "-m", "twbr_runner.runner", str(COURSE), "--out", str(tmp_path / "runs"),
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
