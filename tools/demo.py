"""make demo: run the simulator node with a fixed torque profile and print what it published.

Starts sim_node (lockstep, with the scenario's world) and torque_driver (profile `demo`) as separate
processes on an isolated DDS domain on loopback, listens to every topic of the contract, prints the
robot's state every 0.25 s of sim time, and a summary of each topic at the end. Every process it
started is stopped, also on Ctrl-C and on failure.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import rclpy
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from twbr_common.geometry import rpy_from_quaternion
from twbr_common.processes import loopback_env, start_node
from twbr_common.ros_io import stamp_seconds
from twbr_msgs.msg import ObstacleArray, SimStatus, WorldStatus

ROOT = Path(__file__).resolve().parents[1]
TOPICS = {
    "/clock": Clock, "odom": Odometry, "imu": Imu, "joint_states": JointState, "/tf": TFMessage,
    "sim_status": SimStatus, "target": Odometry, "obstacles": ObstacleArray, "world_status": WorldStatus,
    "world_markers": MarkerArray,
}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=4.0, help="sim time to run [s]")
    ap.add_argument("--scenario", default="dynamic_obstacles", help="scenario whose world the simulator hosts")
    args = ap.parse_args()
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    env = loopback_env(domain)
    log_dir = Path(tempfile.mkdtemp(prefix="twbr-demo-"))
    config = ROOT / "config"
    print(f"demo: sim_node + torque_driver on ROS_DOMAIN_ID={domain} (loopback only); logs in {log_dir}")

    rclpy.init(domain_id=domain)
    node = rclpy.create_node("twbr_demo")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    counts: dict[str, int] = defaultdict(int)
    last: dict[str, object] = {}
    qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)

    rows: list[str] = []
    next_row = [0.0]

    def on_odom_row(msg: Odometry) -> None:
        t = stamp_seconds(msg.header.stamp)
        if t + 1e-9 < next_row[0]:
            return
        next_row[0] += 0.25
        o = msg.pose.pose.orientation
        _, pitch, yaw = rpy_from_quaternion(o.x, o.y, o.z, o.w)
        js = last.get("joint_states")
        imu = last.get("imu")
        effort = f"{js.effort[0]:+7.3f} {js.effort[1]:+7.3f}" if js else "      -       -"
        accel = f"{imu.linear_acceleration.x:+7.3f}" if imu else "      -"
        rows.append(
            f"{t:5.2f} {msg.pose.pose.position.x:+7.3f} {msg.pose.pose.position.y:+7.3f} {yaw:+7.3f}"
            f" {pitch:+8.4f} {msg.twist.twist.linear.x:+7.3f} {msg.twist.twist.angular.z:+7.3f} {effort} {accel}"
        )
        print(rows[-1], flush=True)

    def keep(topic: str):
        def cb(msg) -> None:
            counts[topic] += 1
            last[topic] = msg
            if topic == "odom":
                on_odom_row(msg)
        return cb

    for topic, kind in TOPICS.items():
        node.create_subscription(kind, topic, keep(topic), qos)
    procs = []
    sim = None
    try:
        # The lockstep simulator holds t = 0 until a command arrives: start it first, start the driver
        # once we hear its initial state, and nothing it publishes is missed here.
        sim = start_node(
            "twbr_sim", "sim_node",
            ["--params-file", str(config / "robot.yaml"), "--params-file", str(config / "sim.yaml"),
             "-p", f"duration:={args.duration}", "-p", f"scenario:={args.scenario}"],
            env, log_dir,
        )
        procs.append(sim)
        deadline = time.monotonic() + 30.0
        while counts["odom"] == 0 and sim.running and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        if counts["odom"] == 0:
            print(f"demo: no state from sim_node\n{sim.output}", file=sys.stderr)
            return 1
        print("    t       x       y     yaw    pitch       v       w  T_left T_right   acc_x")
        print("  [s]     [m]     [m]   [rad]    [rad]   [m/s] [rad/s]   [N*m]   [N*m] [m/s^2]")
        procs.append(start_node("twbr_sim", "torque_driver", ["-p", "profile:=demo"], env, log_dir))
        deadline = time.monotonic() + 60.0 + 5.0 * args.duration
        while sim.running and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        if sim.running:
            print("demo: sim_node did not finish in time", file=sys.stderr)
            return 1
        if sim.proc.returncode != 0:
            print(sim.output, file=sys.stderr)
            return 1
    except KeyboardInterrupt:
        print("demo: interrupted")
        return 130
    finally:
        for p in procs:
            p.stop()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()

    sim_time = stamp_seconds(last["/clock"].clock) if "/clock" in last else 0.0
    print(f"\npublished in {sim_time:.2f} s of sim time (counts as received here, reliable QoS):")
    for topic, kind in TOPICS.items():
        rate = counts[topic] / sim_time if sim_time > 0 else math.nan
        print(f"  {topic:<14} {kind.__module__.split('.')[0] + '/' + kind.__name__:<32} {counts[topic]:6d} msgs"
              f"  {rate:7.1f} Hz")
    status: SimStatus | None = last.get("sim_status")
    if status is not None:
        print(f"sim_status: fallen={status.fallen} pitch={status.pitch:+.3f} rad steps={status.steps}"
              f" commands={status.commands_received} rejected={status.commands_rejected}"
              f" lockstep_timeouts={status.lockstep_timeouts}")
    ws: WorldStatus | None = last.get("world_status")
    if ws is not None:
        print(f"world_status: target_distance={ws.target_distance:.2f} m clearance={ws.clearance:.2f} m"
              f" collisions={ws.collision_count}")
    print(next(line for line in sim.stderr.splitlines() if "stopped at" in line).split("]: ")[-1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
