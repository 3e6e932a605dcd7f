"""sim_node: the simulated robot (and by default its world) on the interface contract's topics.

Subscribes wheel_torque_cmd; publishes clock, odom, imu, joint_states, /tf, sim_status and, hosting the
world, target, obstacles, world_status and world_markers. In lockstep it publishes the state at step k
and integrates to k+1 only once the command stamped with step k's time has arrived (or a wall-clock
timeout has passed, which it counts); in realtime it steps on a wall-clock timer. What to wait for, when
to step and what is due live in `twbr_sim.stepping` (no ROS, unit-tested); this module turns them into
messages.
"""

from __future__ import annotations

import time

from geometry_msgs.msg import PoseArray, Quaternion, TransformStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, LaserScan
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from twbr_common.executor import new_executor
from twbr_common.geometry import quaternion_from_rpy
from twbr_common.graph_watch import GraphWatch
from twbr_common.guard import DropReport, Verdict
from twbr_common.params import ConfigError
from twbr_common.ros_io import (
    CLOCK_PUB_QOS,
    COMMAND_QOS,
    MARKER_QOS,
    SENSOR_PUB_QOS,
    TF_STATIC_QOS,
    WORLD_PUB_QOS,
    flush_publishers,
    stamp_ns,
    stamp_seconds,
    to_stamp,
)
from twbr_common.ros_params import declare, run_node
from twbr_common.wire import stamp_seconds_of
from twbr_msgs.msg import ObstacleArray, PlannerState, SimStatus, WheelTorques, WorldStatus
from twbr_sim import dynamics as dyn
from twbr_sim.encoders import J_ANGLE_LEFT, J_ANGLE_RIGHT, J_RATE_LEFT, J_RATE_RIGHT, J_VELOCITY, J_X, J_Y, J_YAW, J_YAW_RATE
from twbr_sim.robot_params import P_R, ROBOT_SPECS, robot_params
from twbr_sim.run_report import LatencyRecord, rates_text
from twbr_sim.scan_messages import laser_scan, laser_transform, target_detections, target_sensor_transform
from twbr_sim.scenario import Scenario, command_at, load_scenario
from twbr_sim.scenario_files import find_scenario
from twbr_sim.simulator import SIM_SPECS, Simulator, steps_per_publish
from twbr_sim.stepping import LockstepExchange, Publications, RealtimeTicks, TimeoutAction
from twbr_sim.traction import TF_DEMAND_LEFT, TF_DEMAND_RIGHT, TF_NORMAL_LEFT, TF_NORMAL_RIGHT
from twbr_sim.world_messages import obstacles_message, target_message, world_markers, world_status_message

WHEEL_JOINTS = ["left_wheel_joint", "right_wheel_joint"]


# [s] at most, at a run's end, for every reliable subscriber to acknowledge the run's last messages (its
# outcome: the world_status that says the target was reached, the final counters). With four busy loops
# beside the fault course on 2 cores, /clock's last samples took 1.3-1.9 s. At the former 1 s a CI run of
# that course read as not reached from its bag, though the runner had seen the target reached. It returns
# as soon as they are acknowledged.
RUN_END_FLUSH_S = 10.0


class SimNode(Node):
    """The robot on the contract's topics. A driver on another physics engine subclasses it and replaces
    `robot_parameters` and `new_simulator` (twbr_mujoco.mujoco_driver): the stepping, the messages and the
    world are this class's."""

    SPECS: tuple = SIM_SPECS
    ENGINE = "ideal-model"

    def __init__(self, node_name: str = "sim_node") -> None:
        super().__init__(node_name)
        cfg = declare(self, self.SPECS)
        robot = self.robot_parameters(cfg)
        if self.get_parameter("use_sim_time").value:
            raise ConfigError(f"invalid parameter 'use_sim_time' = True: {node_name} is the clock; must be false")
        scenario = load_scenario(find_scenario(cfg["scenario"])) if cfg["scenario"] else None
        seed = cfg["seed"] if cfg["seed"] >= 0 else (scenario.seed if scenario else 0)
        self.cfg = cfg
        self.sim = self.new_simulator(robot, cfg, scenario, seed)
        self.sim.warm_up()  # before any publisher: the first state goes out on time
        self.lockstep = cfg["mode"] == "lockstep"
        self._frame_odom = cfg["odom_frame"]
        self._frame_base = cfg["base_frame"]
        self._commands_received = 0
        self._status_flags: tuple | None = None
        self._published_at: float | None = None
        self._prepared: tuple[int, bool, list] | None = None  # (stamp ns, clock due, world messages) to send
        self._latencies = LatencyRecord()
        self.drops = DropReport(self.get_logger().warning)

        self._clock_msg, self._odom_msg, self._imu_msg = self._control_messages()
        self.pub_clock = self.create_publisher(Clock, "/clock", CLOCK_PUB_QOS)
        self.pub_odom = self.create_publisher(Odometry, "odom", SENSOR_PUB_QOS)
        self.pub_imu = self.create_publisher(Imu, "imu", SENSOR_PUB_QOS)
        self.pub_joints = self.create_publisher(JointState, "joint_states", SENSOR_PUB_QOS)
        # Realistic sensors: odom is dead reckoning and the imu is noisy, so the true state goes out beside
        # them for the record (metrics, figures); with ideal sensors odom is the true state.
        self.pub_truth = (None if self.sim.ideal_sensors
                          else self.create_publisher(Odometry, "ground_truth", SENSOR_PUB_QOS))
        self.pub_tf = self.create_publisher(TFMessage, "/tf", SENSOR_PUB_QOS)
        self.pub_scan = self.pub_detections = None
        static = []  # the sensors above base_link, in one latched message
        if cfg["lidar.rate"] > 0.0:
            self.pub_scan = self.create_publisher(LaserScan, "scan", SENSOR_PUB_QOS)
            static.append(laser_transform(cfg, cfg["base_frame"], to_stamp(0)))
        if cfg["target_sensor.rate"] > 0.0 and scenario is not None and scenario.target is not None:
            self.pub_detections = self.create_publisher(PoseArray, "target_detections", SENSOR_PUB_QOS)
            static.append(target_sensor_transform(cfg, cfg["base_frame"], to_stamp(0)))
        if static:
            self.pub_tf_static = self.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
            self.pub_tf_static.publish(TFMessage(transforms=static))
        self.pub_status = self.create_publisher(SimStatus, "sim_status", WORLD_PUB_QOS)
        self.hosting_world = scenario is not None and cfg["host_world"]
        if self.hosting_world:
            self.pub_target = self.create_publisher(Odometry, "target", WORLD_PUB_QOS)
            self.pub_obstacles = self.create_publisher(ObstacleArray, "obstacles", WORLD_PUB_QOS)
            self.pub_world_status = self.create_publisher(WorldStatus, "world_status", WORLD_PUB_QOS)
            self.pub_markers = self.create_publisher(MarkerArray, "world_markers", MARKER_QOS)
        self.create_subscription(WheelTorques, "wheel_torque_cmd", self._on_command, COMMAND_QOS)
        owned = ["/clock", "odom", "imu", "joint_states", "sim_status"]
        self.graph = GraphWatch(self, owned + (["target", "obstacles", "world_status"] if self.hosting_world else []))
        # Lockstep with the planner too: it is not in the torque loop, and a starved planner process would
        # otherwise fall behind a simulator running faster than real time (its cmd_vel then goes stale).
        self._last_assessment = None
        planner_every = 0
        if self.lockstep and cfg["lockstep_planner_rate"] > 0.0:
            planner_every = steps_per_publish(cfg["physics_rate"], cfg["lockstep_planner_rate"])
            if planner_every % self.sim.steps_per_publish:
                raise ConfigError(
                    f"invalid parameter 'lockstep_planner_rate' = {cfg['lockstep_planner_rate']:g}: must divide"
                    f" publish_rate = {cfg['publish_rate']:g} Hz into a whole number of states"
                )
            self.create_subscription(PlannerState, "planner_state", self._on_planner_state, COMMAND_QOS)
        self.exchange = LockstepExchange(planner_every, cfg["wait_for_first_command"])
        # A scripted profile's player is not in the torque loop either: at each change of the profile the state
        # waits for the new command, which the simulator knows from the same scenario file.
        self._script = scenario if self.lockstep and cfg["lockstep_commands"] and scenario and scenario.commands else None
        self._script_last: tuple[float, float] | None = None
        if self._script is not None:
            self.create_subscription(Twist, "cmd_vel", self._on_cmd_vel, COMMAND_QOS)
        self.publications = Publications(cfg["clock_rate"] if cfg["clock_rate"] > 0.0 else cfg["publish_rate"],
                                         cfg["world_rate"], cfg["tf_rate"], cfg["marker_rate"], cfg["lidar.rate"],
                                         cfg["target_sensor.rate"] if self.pub_detections is not None else 0.0)
        self.get_logger().info(
            f"{cfg['mode']} {self.ENGINE} simulation at {cfg['physics_rate']:g} Hz, state every"
            f" {self.sim.steps_per_publish} steps, scenario: {scenario.name if scenario else 'none'},"
            f" seed {seed}, {f'for {self.duration:g} s' if self.duration > 0.0 else 'until stopped'}"
        )

    def robot_parameters(self, cfg: dict) -> dict:
        return declare(self, ROBOT_SPECS)

    def new_simulator(self, robot: dict, cfg: dict, scenario: Scenario | None, seed: int) -> Simulator:
        return Simulator(robot_params(robot), cfg, scenario, seed)

    # --- inputs -------------------------------------------------------------------------------
    def _on_command(self, msg: WheelTorques) -> None:
        self._commands_received += 1
        stamp = stamp_seconds(msg.header.stamp)
        result = self.sim.offer_command(stamp, msg.left, msg.right)
        if result.verdict is not Verdict.ACCEPTED:
            self.drops.dropped("wheel_torque_cmd", result.verdict.value,
                               f"left={msg.left:.6g}, right={msg.right:.6g}, stamp {stamp:.3f} s at t ="
                               f" {self.sim.time:.3f} s")
            return
        if result.saturated:
            self.get_logger().warning(
                f"wheel_torque_cmd past the motor limit {self.sim.torque_limit:g} N*m: clipped",
                throttle_duration_sec=1.0,
            )
        if self.exchange.command(stamp_ns(msg.header.stamp)) and self._published_at is not None:
            # State published -> its command received: the whole control loop over DDS.
            self._latencies.add(time.perf_counter() - self._published_at)

    def _on_cmd_vel(self, msg: Twist) -> None:
        self.exchange.scripted((msg.linear.x, msg.angular.z))

    def _on_planner_state(self, msg: PlannerState) -> None:
        self.exchange.planner(stamp_ns(msg.header.stamp))

    # --- outputs ------------------------------------------------------------------------------
    def publish_control_state(self) -> None:
        self.prepare_control_state()
        self.send_control_state()

    def prepare_control_state(self) -> None:
        """Fill the messages of the current state: the clock, the world and the scan when due, odom and imu.

        Apart from sending, so that realtime can fill them in the slack of the period before and send them
        at the tick: filling is Python, several times slower on a CPU that just woke up, and it would sit in
        the control loop's latency (benchmarks/README.md).
        """
        sim = self.sim
        now_ns = sim.stamp_ns
        stamp = to_stamp(now_ns)
        self._clock_msg.clock = stamp
        due = self.publications.with_state(sim.time, self.hosting_world)
        world = self.world_messages(stamp) if due.world else []
        if due.scan:
            world.append((self.pub_scan, laser_scan(self.cfg, sim.scan(), stamp)))
        if due.detections:
            world.append((self.pub_detections, target_detections(self.cfg, sim.target_detection(), stamp)))
        s = sim.state
        sample = sim.sense()
        e = sample.encoders
        odom = self._odom_msg
        odom.header.stamp = stamp
        pose = odom.pose.pose
        # Pose and twist as the wheel odometry gives them; the pitch and its rate are the true ones (ground
        # truth for the bag's metrics: the controller takes them from the imu only).
        pose.position.x, pose.position.y = e[J_X], e[J_Y]
        q = pose.orientation
        q.x, q.y, q.z, q.w = quaternion_from_rpy(0.0, s[dyn.S_TH], e[J_YAW])
        twist = odom.twist.twist
        twist.linear.x, twist.angular.y, twist.angular.z = e[J_VELOCITY], s[dyn.S_THD], e[J_YAW_RATE]

        reading = sample.imu
        imu = self._imu_msg
        imu.header.stamp = stamp
        if not sim.imu_model.raw:
            q = imu.orientation
            q.x, q.y, q.z, q.w = quaternion_from_rpy(reading.roll, reading.pitch, reading.yaw)
        av, la = imu.angular_velocity, imu.linear_acceleration
        av.x, av.y, av.z = reading.angular_velocity
        la.x, la.y, la.z = reading.linear_acceleration
        self._prepared = (now_ns, due.clock, world)

    def send_control_state(self, again: bool = False) -> None:
        """What the controller and the planner act on, first, so their answers are not held up: the clock,
        the world and the scan when due (before odom, so a planner triggered by odom, or a tracker that
        places a scan with the odom of its instant, has them for the same instant), then odom and imu back
        to back (the controller computes once it has both). `again` offers the same state once more (held
        at t = 0), with its clock and world: a node that missed them (its subscription matched after they
        went out, e.g. a simulator restarted beside running nodes whose clock still reads the old run's
        end) learns of the new run from the next offer, however long discovery takes."""
        now_ns, clock_due, world = self._prepared
        self._published_at = time.perf_counter()
        if clock_due or again:
            self.pub_clock.publish(self._clock_msg)
        publish_each(world)
        self.pub_odom.publish(self._odom_msg)
        self.pub_imu.publish(self._imu_msg)
        if self.pub_truth is not None and not again:
            self.pub_truth.publish(self.truth_message())
        # A new state: its command is awaited (lockstep) and its latency measured (both); and the profile's
        # command where it changes at a state the player sees (one with /clock: it plays on /clock's time), where
        # the player has gone quiet (starved: its keep-alives keep the controller's cmd_vel fresh), and at the
        # first state, held until the player is heard (it may join after the clock starts).
        expected = None
        if self._script is not None and (clock_due or again):
            v, w = command_at(self._script, stamp_seconds_of(now_ns))
            value = (float(v), float(w))
            changed = again or self._script_last is None or value != self._script_last
            expected = value if changed or self.exchange.script_quiet(value, now_ns) else None
            self._script_last = value
        self.exchange.offered(now_ns, self.sim.step_count, expected)

    def _control_messages(self) -> tuple[Clock, Odometry, Imu]:
        """The clock, odom and imu messages every state refills: publish() serializes at once, and building
        them afresh (nested messages, two covariance arrays each) was a large part of publishing a state."""
        odom = Odometry()
        odom.header.frame_id = self._frame_odom
        odom.child_frame_id = self._frame_base
        odom.pose.pose.position.z = float(self.sim.p[P_R])
        imu = Imu()
        imu.header.frame_id = self._frame_base
        cfg = self.cfg
        for cov, std in (
            (imu.orientation_covariance, cfg["imu.orientation_noise_std"]),
            (imu.angular_velocity_covariance, cfg["imu.gyro_noise_std"]),
            (imu.linear_acceleration_covariance, cfg["imu.accel_noise_std"]),
        ):
            cov[0] = cov[4] = cov[8] = std * std
        if cfg["imu.raw"]:  # REP 145: no orientation estimate
            imu.orientation_covariance[0] = -1.0
            imu.orientation.w = 0.0
        return Clock(), odom, imu

    def publish_telemetry(self) -> None:
        publish_each(self.telemetry_messages())

    def telemetry_messages(self) -> list[tuple]:
        """(publisher, message) of everything else about the state just answered: joints, tf, markers,
        status."""
        return self.state_telemetry() + self.answer_telemetry()

    def state_telemetry(self) -> list[tuple]:
        """Joints, tf and markers of the current state. They do not depend on its command, so lockstep
        builds them while the command is awaited, not between the command and the next state (the
        critical path); they are sent after the next state, like the rest."""
        sim = self.sim
        stamp = to_stamp(self.exchange.pending_ns)
        joints = JointState()
        joints.header.stamp = stamp
        joints.name = WHEEL_JOINTS
        e = sim.sense().encoders
        joints.position = [float(e[J_ANGLE_LEFT]), float(e[J_ANGLE_RIGHT])]
        joints.velocity = [float(e[J_RATE_LEFT]), float(e[J_RATE_RIGHT])]
        joints.effort = list(sim.wheel_torques())
        out: list[tuple] = [(self.pub_joints, joints)]

        due = self.publications.with_state_telemetry(sim.time, self.hosting_world)
        if due.tf:
            tf = TransformStamped()
            tf.header.stamp = stamp
            tf.header.frame_id = self._frame_odom
            tf.child_frame_id = self._frame_base
            tr, pose = tf.transform.translation, self._odom_msg.pose.pose  # the pose odom went out with
            tr.x, tr.y, tr.z = pose.position.x, pose.position.y, pose.position.z
            q = pose.orientation
            tf.transform.rotation = Quaternion(x=q.x, y=q.y, z=q.z, w=q.w)  # odom's is refilled next state
            out.append((self.pub_tf, TFMessage(transforms=[tf])))
        if due.markers and self.pub_markers.get_subscription_count():  # built only while a viewer listens
            world = sim.world
            out.append((self.pub_markers, world_markers(world.target(), world.obstacles(), world.capture_radius,
                                                        stamp, self._frame_odom)))
        return out

    def answer_telemetry(self) -> list[tuple]:
        """sim_status, when due or a flag changed: its flags include the command's (torque saturated,
        command stale)."""
        sim = self.sim
        flags = (sim.fallen, sim.torque_saturated, sim.command_stale, sim.traction.lifted, sim.traction.slipping)
        if self._status_flags is not None and flags[2] != self._status_flags[2]:
            self._report_command_stale(sim.command_stale)
        if not self.publications.status_due(sim.time, flags != self._status_flags):
            return []
        self._status_flags = flags
        return [(self.pub_status, self.status_message(to_stamp(self.exchange.pending_ns)))]

    def _report_command_stale(self, stale: bool) -> None:
        if stale:
            self.get_logger().error(
                f"no valid wheel_torque_cmd for command_timeout = {self.cfg['command_timeout']:g} s at"
                f" t = {self.sim.time:.3f} s: zero torque until one arrives"
            )
        else:
            self.get_logger().info(f"wheel_torque_cmd arriving at t = {self.sim.time:.3f} s: torque applied")

    def truth_message(self) -> Odometry:
        s = self.sim.state
        msg = Odometry()
        msg.header.stamp = self._odom_msg.header.stamp
        msg.header.frame_id = self._frame_odom
        msg.child_frame_id = self._frame_base
        pose = msg.pose.pose
        pose.position.x, pose.position.y, pose.position.z = s[dyn.S_XC], s[dyn.S_YC], float(self.sim.p[P_R])
        q = pose.orientation
        q.x, q.y, q.z, q.w = quaternion_from_rpy(0.0, s[dyn.S_TH], s[dyn.S_PSI])
        twist = msg.twist.twist
        twist.linear.x, twist.angular.y, twist.angular.z = s[dyn.S_XD], s[dyn.S_THD], s[dyn.S_PSID]
        return msg

    def status_message(self, stamp) -> SimStatus:
        sim = self.sim
        msg = SimStatus()
        msg.header.stamp = stamp
        msg.header.frame_id = self._frame_base
        msg.fallen = sim.fallen
        msg.pitch = float(sim.state[dyn.S_TH])
        msg.torque_saturated = sim.torque_saturated
        msg.command_stale = sim.command_stale
        msg.commands_received = self._commands_received
        msg.commands_rejected = sim.guard.rejected_total
        msg.lockstep_timeouts = sim.lockstep_timeouts
        msg.steps = sim.step_count
        loads, tally = sim.sense().loads, sim.traction
        msg.normal_force_left, msg.normal_force_right = float(loads[TF_NORMAL_LEFT]), float(loads[TF_NORMAL_RIGHT])
        msg.friction_demand_left = float(loads[TF_DEMAND_LEFT])
        msg.friction_demand_right = float(loads[TF_DEMAND_RIGHT])
        msg.wheel_lifted, msg.wheel_slipping = tally.lifted, tally.slipping
        msg.lift_events, msg.slip_events = tally.lift_events, tally.slip_events
        msg.lifted_time = tally.lifted_samples / self.cfg["publish_rate"]
        msg.slipping_time = tally.slipping_samples / self.cfg["publish_rate"]
        return msg

    def world_messages(self, stamp) -> list[tuple]:
        """(publisher, message) of the world at this state: target, obstacles, world_status."""
        world = self.sim.world
        out = []
        target = world.target()
        if target is not None:
            out.append((self.pub_target, target_message(target, stamp, self._frame_odom)))
        out.append((self.pub_obstacles, obstacles_message(world.obstacles(), stamp, self._frame_odom)))
        assessment = self.sim.assess()
        self._last_assessment = assessment
        out.append((self.pub_world_status,
                    world_status_message(assessment, world.collision_count, stamp, self._frame_odom)))
        return out

    # --- stepping -----------------------------------------------------------------------------
    @property
    def duration(self) -> float:
        """The run's length [s]: the parameter, or the scenario's own when the parameter is negative (so a
        by-hand `-p scenario:=...` ends as the runner's run of it does); 0: until stopped."""
        duration = self.cfg["duration"]
        if duration < 0.0:
            return self.sim.scenario.duration if self.sim.scenario is not None else 0.0
        return duration

    def _finished(self) -> bool:
        duration = self.duration
        return (duration > 0.0 and self.sim.time >= duration - 1e-12) or self._target_reached_end

    @property
    def _target_reached_end(self) -> bool:
        """The scenario ends when its target is reached (end_on_target), judged at the world rate."""
        scenario = self.sim.scenario
        return bool(scenario and scenario.end_on_target and self._last_assessment is not None
                    and self._last_assessment.target_reached)

    def _wait_for_subscribers(self) -> None:
        wanted = self.cfg["wait_for_subscribers"]
        if wanted == 0:
            return
        self.get_logger().info(f"waiting for {wanted} odom subscriber(s)")
        while self.context.ok() and self.pub_odom.get_subscription_count() < wanted:
            self._executor.spin_once(timeout_sec=0.02)

    def run(self) -> None:
        self._wall_start: float | None = None
        self._exchanges = 0
        # One executor for the whole run: this node drives its own loop and spins only between steps.
        self._executor = new_executor(self.context)
        self._executor.add_node(self)
        self._wait_for_subscribers()
        if self.lockstep:
            self._run_lockstep()
        else:
            self._run_realtime()
        self._executor.remove_node(self)
        wall = time.monotonic() - self._wall_start if self._wall_start is not None else 0.0
        if self.context.ok():
            final = to_stamp(self.sim.stamp_ns)
            self.pub_status.publish(self.status_message(final))  # the run's final counters
            if not flush_publishers(self, RUN_END_FLUSH_S):
                self.get_logger().warning(f"a reliable subscriber had not acknowledged the run's last messages"
                                          f" after {RUN_END_FLUSH_S:g} s: a recording may lack its end")
        rates = rates_text(self._exchanges, wall, self.sim.time - self._sim_start) if wall > 0 else ""
        latency = self._latencies.text()
        self.get_logger().info(
            f"stopped at t = {self.sim.time:.3f} s after {self.sim.step_count} steps,"
            f" {self.sim.lockstep_timeouts} lockstep timeouts{rates}{latency}"
        )

    def _step(self) -> None:
        if self._wall_start is None:
            self._wall_start = time.monotonic()
            self._sim_start = self.sim.time
        self.sim.advance(self.sim.steps_per_publish)
        self._exchanges += 1

    def _run_lockstep(self) -> None:
        """Offer a state, wait for its answers, step. The answered state's telemetry goes out after the next
        state, while the controller computes on it: not between the answer and the next state (the critical
        path). At a state the planner answers too, controller and planner already fill both cores of a small
        machine: there the telemetry is held until the controller's command is in (it then goes out while the
        planner's answer is awaited), not sent beside them (benchmarks/README.md, issue 19)."""
        executor = self._executor
        exchange = self.exchange
        timeout = self.cfg["lockstep_timeout"]
        self.publish_control_state()
        state_telemetry: list[tuple] = self.state_telemetry()
        held: list[tuple] | None = None
        while self.context.ok() and not self._finished():
            deadline = time.monotonic() + timeout
            while not exchange.answered() and self.context.ok():
                if held is not None and exchange.command_matched:
                    state_telemetry, held = self._release(held), None
                remaining = deadline - time.monotonic()
                if remaining <= 0.0:
                    break
                executor.spin_once(timeout_sec=remaining)
            if held is not None:
                state_telemetry, held = self._release(held), None
            if not exchange.answered():
                missing = exchange.missing().value
                if exchange.timed_out() is TimeoutAction.OFFER_AGAIN:
                    self.send_control_state(again=True)  # nobody has answered yet: offer it again
                    self.get_logger().warning(
                        f"holding t = 0: no {missing} for the first state yet (is every node of the graph"
                        " running, on this ROS_DOMAIN_ID and on sim time?)", throttle_duration_sec=5.0)
                    continue
                self.sim.lockstep_timeouts += 1
                self.get_logger().warning(
                    f"lockstep timeout at t = {self.sim.time:.3f} s: no {missing}"
                    f" within {timeout:g} s wall; stepping on ({self.sim.lockstep_timeouts} so far)",
                    throttle_duration_sec=1.0,
                )
            exchange.stepping()
            telemetry = state_telemetry + self.answer_telemetry()
            self._step()
            self.publish_control_state()
            if exchange.planner_due:
                held = telemetry
            else:
                state_telemetry = self._release(telemetry)
        if held is not None:
            state_telemetry = self._release(held)
        publish_each(state_telemetry + self.answer_telemetry())

    def _release(self, telemetry: list[tuple]) -> list[tuple]:
        """Send the answered state's telemetry; return the current state's (built while its answer is awaited)."""
        publish_each(telemetry)
        return self.state_telemetry()

    def _run_realtime(self) -> None:
        """Each period: the state at its tick, then the controller's answer, then telemetry and the next
        state, prepared in the slack (stepping.RealtimeTicks)."""
        executor = self._executor
        exchange = self.exchange
        self.publish_control_state()
        ticks = RealtimeTicks(1.0 / (self.cfg["publish_rate"] * self.cfg["real_time_factor"]), time.monotonic())
        while self.context.ok():
            if ticks.telemetry_due(exchange.command_matched, time.monotonic()):
                ticks.telemetry_done()
                self.publish_telemetry()
                if self._finished():
                    break
                if exchange.command_matched:
                    self._step()
                    self.prepare_control_state()
                    ticks.prepared = True
            executor.spin_once(timeout_sec=max(0.0, ticks.wake_at() - time.monotonic()))
            now = time.monotonic()
            if ticks.tick_due(now):
                if ticks.telemetry_by is not None:
                    ticks.telemetry_done()
                    self.publish_telemetry()
                    if self._finished():
                        break
                if not ticks.prepared:
                    self._step()
                    self.prepare_control_state()
                self.send_control_state()
                ticks.sent(now)
        if ticks.telemetry_by is not None:
            self.publish_telemetry()


def publish_each(messages: list[tuple]) -> None:
    """(publisher, message) pairs, in order: the world with a state, telemetry after it."""
    for publisher, msg in messages:
        publisher.publish(msg)


def main(args: list[str] | None = None) -> int:
    return run_node("sim_node", SimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
