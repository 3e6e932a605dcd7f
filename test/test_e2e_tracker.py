"""tracker_node as a process: sim_node's scan and odom in, obstacles out, against the world's truth."""

from __future__ import annotations

import math

import pytest
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, ReliabilityPolicy

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.ros_io import stamp_ns
from twbr_msgs.msg import ObstacleArray, WheelTorques
from twbr_tracker.tracker import WALL_IDS

pytestmark = pytest.mark.e2e

RELIABLE = QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE)


def turning_in_place(odom: Odometry) -> tuple[float, float]:
    """A pitch PD that keeps the robot up, and a differential torque that turns it (~1 rad/s): the scan's
    beams then see the people from a turning robot, which the tracker must deskew."""
    o = odom.pose.pose.orientation
    _, pitch, _ = rpy_from_quaternion(o.x, o.y, o.z, o.w)
    balance = 30.0 * pitch + 4.0 * odom.twist.twist.angular.y
    turn = 0.4 * (1.0 - odom.twist.twist.angular.z)
    return balance - turn, balance + turn


def test_tracks_are_where_the_world_s_obstacles_are(launch, ros):
    """Twelve people crossing (suite/crowd_crossing), the robot balancing at its start while it turns at
    ~1 rad/s: every track is on a person, and the people within 4 m are
    tracked (some hide behind others: not all of them)."""
    duration = 6.0
    tracker = launch("twbr_tracker", "tracker_node", "-r", "obstacles:=tracked",
                     params=("tracker.yaml",))
    sim = launch("twbr_sim", "sim_node", "-p", f"duration:={duration}", "-p", "scenario:=suite/crowd_crossing",
                 "-p", "wait_for_subscribers:=2", params=("robot.yaml", "sim.yaml"))
    truth: dict[int, ObstacleArray] = {}
    tracked: list[ObstacleArray] = []
    poses: dict[int, tuple[float, float]] = {}
    yaw_rates: list[float] = []
    ros.node.create_subscription(ObstacleArray, "obstacles", lambda m: truth.setdefault(stamp_ns(m.header.stamp), m),
                                 RELIABLE)
    ros.node.create_subscription(ObstacleArray, "tracked", tracked.append, RELIABLE)
    pub = ros.node.create_publisher(WheelTorques, "wheel_torque_cmd", RELIABLE)

    def on_odom(msg: Odometry) -> None:
        poses[stamp_ns(msg.header.stamp)] = (msg.pose.pose.position.x, msg.pose.pose.position.y)
        yaw_rates.append(msg.twist.twist.angular.z)
        left, right = turning_in_place(msg)
        pub.publish(WheelTorques(header=msg.header, left=left, right=right))

    ros.node.create_subscription(Odometry, "odom", on_odom, RELIABLE)
    assert ros.spin_until(lambda: sim.proc.poll() is not None, 60.0), sim.output
    ros.spin_until_quiet(lambda: len(tracked))  # the tracker is not in the lockstep: it may lag behind
    assert sim.proc.returncode == 0, sim.output
    assert len(tracked) >= 50, (len(tracked), tracker.output)  # 10 Hz of 6 s of sim time
    assert all(m.header.frame_id == "odom" for m in tracked)
    assert sum(yaw_rates[len(yaw_rates) // 2:]) / (len(yaw_rates) - len(yaw_rates) // 2) > 0.5  # it turned
    errors, near_seen, near_total = [], 0, 0
    for msg in tracked:
        ns = stamp_ns(msg.header.stamp)
        if ns < 1_000_000_000 or ns not in truth:
            continue  # a track is confirmed after three scans
        world = truth[ns].obstacles
        rx, ry = poses[ns]
        tracks = [o for o in msg.obstacles if o.id < WALL_IDS]
        for o in tracks:  # every track is one of the world's obstacles
            errors.append(min(math.hypot(o.position.x - w.position.x, o.position.y - w.position.y) for w in world))
        for w in world:  # and the obstacles near the robot are tracked
            if math.hypot(w.position.x - rx, w.position.y - ry) - w.radius < 4.0:
                near_total += 1
                near_seen += any(math.hypot(o.position.x - w.position.x, o.position.y - w.position.y) < 0.2
                                 for o in tracks)
    errors.sort()
    # Most tracks sit on their person (median ~0.03 m). A person half hidden behind another is fitted to the
    # arc that shows (off by up to a radius), and a hidden one's track coasts on its prediction for up to
    # tracking.max_misses scans: issue 36 leaves those to be measured "while visible"; none is far off.
    assert errors and errors[len(errors) // 2] < 0.05 and errors[int(0.9 * len(errors))] < 0.25, errors[-10:]
    # The furthest off: a person who stops (crowd_crossing's walkers pause at their waypoints) or turns while
    # hidden, the track coasting on at up to 0.68 m/s for tracking.max_misses = 5 scans at 10 Hz (0.34 m), and
    # fitted to the arc of a half-hidden disc when seen again (up to its 0.3 m radius): 0.64 m. (0.6 failed
    # once in CI at 0.608.)
    assert errors[-1] < 0.3 + 5 * 0.1 * 0.68
    assert near_total > 0 and near_seen / near_total >= 0.7, (near_seen, near_total)
    tracker.stop()
    assert "scans tracked" in tracker.output
