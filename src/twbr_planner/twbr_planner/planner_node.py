"""planner_node: the APF planner as a ROS 2 node (a thin adapter over twbr_planner.apf).

Subscribes odom (sensor-data QoS), target (nav_msgs/Odometry: pose, and forward speed along its
heading) and obstacles (twbr_msgs/ObstacleArray); publishes cmd_vel (Twist, or TwistStamped with
enable_stamped_cmd_vel), planner_state and planner_markers (the three forces as arrows). It plans at
`rate` in odom stamps, so it runs on sim time and wall time alike; an odom it will not answer is dropped
before it is read. No plan goes out before the first target and obstacle list (a run's first state is
answered the same however long discovery took). Odom, target and obstacles are read in place from their
bytes (twbr_common.cdr), not deserialized: they arrive together at a planning instant, when the controller
computes too. A plan at odom stamp t waits (at most world_wait of wall time) for the world of its instant,
a target stamped after t - world_period and obstacles after t - obstacles_period: the world of each
planning instant reaches the plan even when a loaded machine delivers it after the odom, so a lockstep run
is the same on an idle and on a busy machine.
Obstacles are moved along their velocity to the odom stamp; a target or obstacle list older than
world_timeout stops the robot, and so does a target whose pose covariance[0] is -1 (a tracker's target
not seen yet: position unknown).
"""

from __future__ import annotations

import math
import time

import numpy as np
from geometry_msgs.msg import Twist, TwistStamped, Vector3
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from visualization_msgs.msg import MarkerArray

from twbr_common.cdr import OdomPose, header_stamp_seconds, odom_pose
from twbr_common.geometry import rpy_from_quaternion
from twbr_common.graph_watch import GraphWatch
from twbr_common.guard import POSITION_LIMIT
from twbr_common.jit import loading_kernels
from twbr_common.markers import arrow
from twbr_common.ros_io import COMMAND_PUB_QOS, MARKER_QOS, SENSOR_PUB_QOS, SENSOR_SUB_QOS, WORLD_QOS, stamp_seconds
from twbr_common.ros_params import accept_changes, declare, input_streams, run_node
from twbr_common.timing import Decimator
from twbr_msgs.msg import ObstacleArray, PlannerState
from twbr_planner.apf import Mode, Obstacles
from twbr_planner.planner import ApfPlanner, PlannerOutput, Target
from twbr_planner.planner_params import APF_SPECS, NODE_SPECS, check_consistent, check_within_robot, describe
from twbr_sim.robot_limits import limits_from_file

FORCE_COLORS = {"attractive": (0.1, 0.8, 0.2, 1.0), "repulsive": (0.9, 0.2, 0.2, 1.0), "total": (0.2, 0.4, 1.0, 1.0)}
# Arrow length per unit of force: the direction is what steers, the length only has to be readable.
FORCE_SCALE = 0.2


class PlannerNode(Node):
    def __init__(self) -> None:
        super().__init__("planner_node")
        cfg = check_consistent({**declare(self, APF_SPECS), **declare(self, NODE_SPECS)})
        self.limits = limits_from_file(cfg["robot_file"])
        self.cfg = check_within_robot(cfg, self.limits)
        self.core = ApfPlanner(self.cfg, self.cfg["rate"])
        loaded = loading_kernels(self.get_logger().info, "the planner", 25.0)
        self.core.warm_up()  # before any publisher: once peers see this node, it answers on time
        loaded()
        self.inputs = input_streams(self)
        self.inputs.add("odom", self.cfg["odom_timeout"], limit=POSITION_LIMIT)
        # Stale on arrival, out of order or unstamped: a bad world sample must never replace a good one.
        self.inputs.add("target", self.cfg["world_timeout"], limit=POSITION_LIMIT)
        self.inputs.add("obstacles", self.cfg["world_timeout"], limit=POSITION_LIMIT)
        self._due = Decimator(self.cfg["rate"])
        self._marker_due = Decimator(self.cfg["marker_rate"])
        # Armed only while a plan waits for its world, on wall time: a lockstep simulator waiting for this plan
        # sends no /clock meanwhile.
        self._overdue = self.create_timer(max(self.cfg["world_wait"], 1e-3), self._plan_overdue,
                                          clock=Clock(clock_type=ClockType.STEADY_TIME), autostart=False)
        self.inputs.on_restart(self._restart)
        self._restart()
        self.stamped = self.cfg["enable_stamped_cmd_vel"]
        self.pub_cmd = self.create_publisher(TwistStamped if self.stamped else Twist, "cmd_vel", COMMAND_PUB_QOS)
        self.pub_state = self.create_publisher(PlannerState, "planner_state", SENSOR_PUB_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, "planner_markers", MARKER_QOS)
        # The executor hands messages over in arrival order, and a simulator publishes the world of an
        # instant before its odom: every world sample queued before the odom that triggers planning is
        # taken first, the newest valid one kept. A queue of one would let a bad message that arrives
        # after a good one evict it.
        self.create_subscription(Odometry, "target", self._on_target_bytes, WORLD_QOS, raw=True)
        self.create_subscription(ObstacleArray, "obstacles", self._on_obstacles_bytes, WORLD_QOS, raw=True)
        self.create_subscription(Odometry, "odom", self._on_odom_bytes, SENSOR_SUB_QOS, raw=True)
        self.graph = GraphWatch(self, ["cmd_vel", "planner_state"])
        self.parameter_revision = 0
        accept_changes(self, (*APF_SPECS, *NODE_SPECS), self.cfg,
                       lambda c: check_within_robot(check_consistent(c), self.limits), self._retune)
        self.get_logger().info(f"planning at {self.cfg['rate']:g} Hz with {describe(self.cfg)}")

    # --- inputs -------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _admit(self, stream: str, stamp: float, values) -> bool:
        return self.inputs.admit(stream, stamp, values, self._now())

    def _restart(self) -> None:
        """Nothing from before a clock jump back (a restarted simulator) survives it, the schedule included."""
        if self.inputs.restarts:
            self.get_logger().warning("clock jumped back: planner, its schedule and its world restarted")
        self.core.reset()
        self._due.restart()
        self._marker_due.restart()
        self._target: tuple[float, Target | None] | None = None  # None in it: position unknown
        self._obstacles: tuple[float, np.ndarray] | None = None  # its stamp; rows of id, x, y, vx, vy, radius
        self._last_plan: tuple[float, PlannerOutput] | None = None
        # (odom, its stamp, yaw, wall deadline): a plan due, waiting for its world.
        self._pending: tuple | None = None
        self._overdue.cancel()

    def _on_target_bytes(self, data: bytes) -> None:
        target = odom_pose(data)
        if target is None:
            self.inputs.dropped("target", "not a nav_msgs/Odometry")
            return
        _, _, heading = rpy_from_quaternion(*target.orientation)
        stamp, speed = stamp_seconds(target.stamp), target.velocity
        if self._admit("target", stamp, (target.x, target.y, heading, speed)):
            self._target = (stamp, Target(target.x, target.y, speed * math.cos(heading), speed * math.sin(heading))
                            if target.known else None)  # a tracker that has not seen it yet: the robot stands
            self._plan_pending()

    def _on_obstacles_bytes(self, data: bytes) -> None:
        admitted = self.inputs.admit_obstacles(data, self._now())
        if admitted is not None:
            self._obstacles = admitted
            self._plan_pending()

    def _on_odom_bytes(self, data: bytes) -> None:
        """Only the odoms the planner answers are read (a tenth of a 200 Hz stream at 20 Hz): its planning
        instants, a state offered again, and any whose stamp the bytes do not show plainly. Read in place:
        deserializing one costs more than the plan's own step, at the instant the controller computes too."""
        stamp = header_stamp_seconds(data)
        if stamp is not None and not self._answers(stamp):
            return
        odom = odom_pose(data)
        if odom is None:
            self.inputs.dropped("odom", "not a nav_msgs/Odometry")
            return
        self._on_odom(odom)

    def _answers(self, stamp: float) -> bool:
        return (self._last_plan is not None and stamp == self._last_plan[0]) or self._due.would_be_due(stamp)

    def _on_odom(self, odom: OdomPose) -> None:
        stamp = stamp_seconds(odom.stamp)
        _, _, yaw = rpy_from_quaternion(*odom.orientation)
        if not self._admit("odom", stamp, (odom.x, odom.y, yaw, odom.velocity)):
            return
        if self._last_plan is not None and stamp == self._last_plan[0]:
            # The same state offered again (a lockstep simulator waiting at t = 0): answer it again.
            self._publish(odom, self._last_plan[1])
        elif self._due.due(stamp):
            if self._pending is not None:
                self._plan_pending(force=True)  # the next instant is due: the last one plans with what it has
            self._pending = (odom, stamp, yaw, time.monotonic() + self.cfg["world_wait"])
            self._overdue.reset()
            self._plan_pending()

    def _retune(self, cfg: dict) -> None:
        self.core.retune(cfg)
        self.parameter_revision += 1

    # --- planning -----------------------------------------------------------------------------
    def _world_current(self, stamp: float) -> bool:
        """Target and obstacles of the planning instant `stamp` are in: stamped after stamp - world_period
        and stamp - obstacles_period (the world's, or a tracker's scans, slower than the plans)."""
        cfg = self.cfg
        return all(sample is not None and sample[0] > stamp - period + 1e-9
                   for sample, period in ((self._target, cfg["world_period"]),
                                          (self._obstacles, cfg["obstacles_period"])))

    @property
    def _has_world(self) -> bool:
        """A target and an obstacle list have come in since the node's (re)start."""
        return self._target is not None and self._obstacles is not None

    def _plan_pending(self, force: bool = False) -> None:
        if self._pending is None or not self._has_world:
            # The first plan waits for its world however long discovery takes: answered without it, the
            # first state's plan (and so the whole run) would depend on which subscription matched first.
            return
        odom, stamp, yaw, deadline = self._pending
        if not (force or self._world_current(stamp) or time.monotonic() >= deadline):
            return
        self._pending = None
        self._overdue.cancel()
        self._plan(odom, stamp, yaw)

    def _plan_overdue(self) -> None:
        self._overdue.cancel()  # one shot: armed again by the next plan that waits
        if self._pending is not None and not self._has_world:
            missing = " and ".join(n for n, v in (("target", self._target), ("obstacles", self._obstacles)) if v is None)
            self.get_logger().warning(
                f"no {missing} yet: the first plan waits for them (is a simulator hosting the world, or"
                " world_node, running on this ROS_DOMAIN_ID?)", throttle_duration_sec=5.0)
        elif self._pending is not None:
            self.get_logger().warning(
                f"no target/obstacles of t = {self._pending[1]:.3f} s within world_wait ="
                f" {self.cfg['world_wait']:g} s: planning with the last ones", throttle_duration_sec=2.0)
            self._plan_pending(force=True)

    def _plan(self, odom: OdomPose, stamp: float, yaw: float) -> None:
        started = time.perf_counter()
        planned = False
        timeout = self.cfg["world_timeout"]
        if self._target is None or self._obstacles is None:
            out = self.core.stopped(stamp, Mode.NO_TARGET)
        elif self._target[1] is None:  # where the target is, is not known (yet): stand, and start afresh
            out = self.core.stopped(stamp, Mode.NO_TARGET)
            self.core.reset()
        elif stamp - self._target[0] > timeout or stamp - self._obstacles[0] > timeout:
            out = self.core.stopped(stamp, Mode.STALE)
            self.core.reset()
            self.get_logger().warn("target or obstacles older than world_timeout: stopping",
                                   throttle_duration_sec=2.0)
        else:
            out = self.core.step(stamp, odom.x, odom.y, yaw, odom.velocity, self._target[1], self._obstacles_at(stamp))
            planned = True
        self._last_plan = (stamp, out)
        self._publish(odom, out, time.perf_counter() - started if planned else 0.0)

    def _obstacles_at(self, stamp: float) -> Obstacles:
        """The obstacle list moved along each obstacle's velocity to `stamp` (it was published earlier)."""
        t0, rows = self._obstacles
        return Obstacles.from_rows(rows, stamp - t0)

    def _publish(self, odom: OdomPose, out: PlannerOutput, planning_time: float = 0.0) -> None:
        twist = Twist()
        twist.linear.x, twist.angular.z = out.velocity_cmd, out.yaw_rate_cmd
        if self.stamped:
            cmd = TwistStamped(twist=twist)
            cmd.header.stamp = odom.stamp
            cmd.header.frame_id = odom.child_frame_id or "base_link"
            self.pub_cmd.publish(cmd)
        else:
            self.pub_cmd.publish(twist)
        # State and markers are for a viewer, a recorder or a lockstep simulator: built only while one
        # listens (CPU the controller beside the planner can use; volatile, so one joining loses nothing).
        if self.pub_state.get_subscription_count():
            self.pub_state.publish(planner_state_message(out, odom, self.cfg, self.parameter_revision, planning_time))
        if self._marker_due.due(out.stamp) and self.pub_markers.get_subscription_count():
            self.pub_markers.publish(force_markers(out, odom))


def _vector(v: np.ndarray) -> Vector3:
    return Vector3(x=float(v[0]), y=float(v[1]), z=0.0)


def planner_state_message(out: PlannerOutput, odom: OdomPose, cfg: dict, parameter_revision: int = 0,
                          planning_time: float = 0.0) -> PlannerState:
    msg = PlannerState(parameter_revision=parameter_revision, planning_time=float(planning_time))
    for name in ("k_p", "k_v", "k_o", "rho_o", "robot_radius", "min_distance"):
        setattr(msg, name, float(cfg[name]))
    msg.header.stamp = odom.stamp
    msg.header.frame_id = odom.frame_id or "odom"
    msg.attractive_force = _vector(out.attractive_force)
    msg.repulsive_force = _vector(out.repulsive_force)
    msg.total_force = _vector(out.total_force)
    msg.desired_heading = float(out.desired_heading)
    msg.heading_error = float(out.heading_error)
    msg.velocity_cmd = float(out.velocity_cmd)
    msg.yaw_rate_cmd = float(out.yaw_rate_cmd)
    msg.distance_to_target = float(out.distance_to_target)
    msg.nearest_obstacle_distance = float(out.nearest_obstacle_distance)
    msg.nearest_obstacle_id = int(out.nearest_obstacle_id)
    msg.mode = out.mode.value
    msg.method = cfg["method"]
    msg.escape_side = int(out.escape_side)
    msg.threat_id = int(out.threat_id)
    msg.active_constraint_id = int(out.active_constraint_id)
    robust = cfg["method"] == "robust"
    msg.repulsion_range = float(cfg["repulsion_range"] if robust else cfg["rho_o"])
    msg.goal_fade = float(cfg["goal_fade"] if robust else 0.0)
    return msg


def force_markers(out: PlannerOutput, odom: OdomPose) -> MarkerArray:
    frame, x, y = odom.frame_id or "odom", odom.x, odom.y
    markers = MarkerArray()
    for mid, (name, force) in enumerate((("attractive", out.attractive_force), ("repulsive", out.repulsive_force),
                                         ("total", out.total_force))):
        end = (x + FORCE_SCALE * force[0], y + FORCE_SCALE * force[1], 0.6)
        markers.markers.append(arrow(odom.stamp, frame, "twbr_planner_forces", mid, (x, y, 0.6), end,
                                     FORCE_COLORS[name]))
    return markers


def main(args: list[str] | None = None) -> int:
    return run_node("planner_node", PlannerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
