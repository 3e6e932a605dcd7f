"""controller_node: the cascaded PID controller as a ROS 2 node (a thin adapter over twbr_control.cascade).

Subscribes odom and imu (sensor-data QoS; read from their bytes, twbr_common.cdr), cmd_vel (Twist, or TwistStamped with
enable_stamped_cmd_vel) and obstacles (its collision monitor limits every cmd_vel's speed before the wheels,
whoever sent it: twbr_control.collision_monitor); publishes wheel_torque_cmd, stamped with the state it was computed from (what
a lockstep simulator waits for), and controller_state. It computes once per state, at most at `rate`,
so it runs in sim time (use_sim_time, /clock) and in wall time alike. Service ~/enable (SetBool).

A cmd_vel takes effect from the first state stamped after it (its stamp, or its arrival on the node's
clock for a plain Twist): state_sync.VelocityCommand.
"""

from __future__ import annotations

from dataclasses import replace

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import Imu
from std_srvs.srv import SetBool

from twbr_common.cdr import ImuFields, OdomTwist, imu_fields, odom_twist
from twbr_common.geometry import rpy_from_quaternion
from twbr_common.graph_watch import GraphWatch
from twbr_common.guard import POSITION_LIMIT, RATE_LIMIT
from twbr_common.ros_io import COMMAND_PUB_QOS, COMMAND_QOS, SENSOR_PUB_QOS, SENSOR_SUB_QOS, WORLD_QOS, stamp_ns, stamp_seconds
from twbr_common.ros_params import accept_changes, declare, input_streams, run_node
from twbr_control.cascade import CascadeController, ControlOutput
from twbr_control.collision_monitor import CollisionMonitor
from twbr_control.controller_params import CONTROL_SPECS, NODE_SPECS, check_consistent, check_within_robot, describe
from twbr_control.estimator import PitchEstimator, uses_estimator
from twbr_control.state_sync import Action, RobotState, StateSync, VelocityCommand
from twbr_msgs.msg import ControllerState, ObstacleArray, WheelTorques
from twbr_sim.robot_limits import limits_from_file


class ControllerNode(Node):
    def __init__(self) -> None:
        super().__init__("controller_node")
        cfg = check_consistent({**declare(self, CONTROL_SPECS), **declare(self, NODE_SPECS)})
        self.limits = limits_from_file(cfg["robot_file"])
        cfg = check_within_robot(cfg, self.limits)
        self.cfg = cfg
        self.controller = CascadeController(cfg, enabled=cfg["start_enabled"])
        self.controller.warm_up()  # before any publisher: once peers see this node, it answers on time
        self.estimator = PitchEstimator(cfg)
        self.sync = StateSync(cfg["rate"], cfg["sync_tolerance"])
        self.command = VelocityCommand(cfg["cmd_vel_timeout"])
        self.monitor = CollisionMonitor(cfg)
        self.inputs = input_streams(self)
        self.inputs.add("odom", cfg["state_timeout"], limit=RATE_LIMIT)
        self.inputs.add("imu", cfg["state_timeout"], limit=RATE_LIMIT)
        stamped = cfg["enable_stamped_cmd_vel"]
        self.inputs.add("cmd_vel", cfg["cmd_vel_timeout"], require_stamp=stamped, limit=RATE_LIMIT)
        self.inputs.add("obstacles", cfg["collision_monitor.obstacle_timeout"], limit=POSITION_LIMIT)
        self.inputs.on_restart(self._restart)
        self._restart()

        self.pub_torque = self.create_publisher(WheelTorques, "wheel_torque_cmd", COMMAND_PUB_QOS)
        self.pub_state = self.create_publisher(ControllerState, "controller_state", SENSOR_PUB_QOS)
        # Raw: the few fields the controller uses are read from the bytes (twbr_common.cdr).
        self.create_subscription(Odometry, "odom", self._on_odom_bytes, SENSOR_SUB_QOS, raw=True)
        self.create_subscription(Imu, "imu", self._on_imu_bytes, SENSOR_SUB_QOS, raw=True)
        if stamped:
            self.create_subscription(TwistStamped, "cmd_vel", self._on_cmd_vel_stamped, COMMAND_QOS)
        else:
            self.create_subscription(Twist, "cmd_vel", self._on_cmd_vel, COMMAND_QOS)
        if cfg["collision_monitor.enabled"]:
            self.create_subscription(ObstacleArray, "obstacles", self._on_obstacles_bytes, WORLD_QOS, raw=True)
        self.create_service(SetBool, "~/enable", self._on_enable)
        self.graph = GraphWatch(self, ["wheel_torque_cmd", "controller_state"])
        self.parameter_revision = 0
        accept_changes(self, (*CONTROL_SPECS, *NODE_SPECS), self.cfg,
                       lambda c: check_within_robot(check_consistent(c), self.limits), self._retune)
        self.get_logger().info(
            f"{describe(cfg)},"
            f" cmd_vel as {'TwistStamped' if stamped else 'Twist'},"
            f" {'enabled' if cfg['start_enabled'] else 'disabled until ~/enable'}"
        )

    # --- inputs -------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _restart(self) -> None:
        """Nothing from before a clock jump back (a restarted simulator, a replayed bag) survives it."""
        if self.inputs.restarts:
            was = " (the old run's fall forgotten)" if self.controller.fallen else ""
            self.get_logger().warning(f"clock jumped back: controller, state pairing and cmd_vel restarted{was}")
        self.sync.reset()
        self.controller.new_run()
        self._reported_fall = False
        self.estimator.reset()
        self._velocity = 0.0  # the last admitted odom's speed, for the estimator [m/s]
        self._estimated = False
        self.command.reset()
        self.monitor.reset()
        self._pose: tuple | None = None  # (stamp, x, y, orientation) of the last odom
        self._last_command: WheelTorques | None = None
        self._stamps: dict[str, Time] = {}

    def _admit(self, stream: str, stamp: float, values: tuple[float, ...]) -> bool:
        return self.inputs.admit(stream, stamp, values, self._now())

    def _on_odom_bytes(self, data: bytes) -> None:
        odom = odom_twist(data)
        if odom is None:
            self.inputs.dropped("odom", "not a nav_msgs/Odometry")
        else:
            self._on_odom(odom)

    def _on_imu_bytes(self, data: bytes) -> None:
        imu = imu_fields(data)
        if imu is None:
            self.inputs.dropped("imu", "not a sensor_msgs/Imu")
        else:
            self._on_imu(imu)

    def _on_odom(self, odom: OdomTwist) -> None:
        stamp = stamp_seconds(odom.stamp)
        if self._admit("odom", stamp, (odom.velocity, odom.yaw_rate)):
            self._velocity = odom.velocity
            self._pose = (stamp, odom.x, odom.y, odom.orientation)  # yaw read only when the monitor needs it
            self._stamps["odom"] = odom.stamp
            self._act(*self.sync.offer_odom(stamp, odom.velocity, odom.yaw_rate))

    def _on_imu(self, imu: ImuFields) -> None:
        stamp = stamp_seconds(imu.stamp)
        gyro_y = imu.angular_velocity[1]
        accel_x, accel_z = imu.linear_acceleration[0], imu.linear_acceleration[2]
        if uses_estimator(self.cfg["pitch_source"], imu.no_orientation):
            if not self._admit("imu", stamp, (gyro_y, accel_x, accel_z)):
                return
            pitch, pitch_rate = self.estimator.update(stamp, gyro_y, accel_x, accel_z, self._velocity)
            velocity = self.estimator.velocity
            self._estimated = True
        else:
            if imu.no_orientation:
                self.get_logger().error("imu reports no orientation (orientation_covariance[0] = -1) and"
                                        " pitch_source is 'orientation': reading dropped; set pitch_source"
                                        " to auto or estimator", throttle_duration_sec=5.0)
                return
            _, pitch, _ = rpy_from_quaternion(*imu.orientation)
            pitch_rate = gyro_y
            if not self._admit("imu", stamp, (pitch, pitch_rate, *imu.orientation)):
                return
            velocity = None
            self._estimated = False
        self._stamps["imu"] = imu.stamp
        self._act(*self.sync.offer_imu(stamp, pitch, pitch_rate, velocity))

    def _on_obstacles_bytes(self, data: bytes) -> None:
        admitted = self.inputs.admit_obstacles(data, self._now())
        if admitted is not None:
            stamp, rows = admitted
            self.monitor.obstacles(stamp, rows)

    def _take_cmd_vel(self, stamp: float, twist: Twist) -> None:
        values = (twist.linear.x, twist.angular.z)
        if self._admit("cmd_vel", stamp, values):
            self.command.offer(stamp, *values)

    def _on_cmd_vel(self, msg: Twist) -> None:
        # An unstamped Twist is as old as its arrival: the node's clock, or the newest state it has, when
        # that state came in before the /clock announcing it.
        self._take_cmd_vel(max(self._now(), self.sync.newest_stamp), msg)

    def _on_cmd_vel_stamped(self, msg: TwistStamped) -> None:
        self._take_cmd_vel(stamp_seconds(msg.header.stamp), msg.twist)

    def _on_enable(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.controller.set_enabled(request.data)
        self._reported_fall = False
        response.success = True
        response.message = "enabled: loops reset" if request.data else "disabled: zero torque"
        self.get_logger().info(response.message)
        return response

    def _retune(self, cfg: dict) -> None:
        self.controller.retune(cfg)
        self.monitor.retune(cfg)
        self.parameter_revision += 1

    # --- control ------------------------------------------------------------------------------
    def _act(self, action: Action, state: RobotState | None) -> None:
        if action is Action.REPEAT and self._last_command is not None:
            self.pub_torque.publish(self._last_command)
        elif action is Action.COMPUTE and state is not None:
            velocity_ref, yaw_rate_ref, stale = self.command.at(state.stamp)
            limited = False
            if self._pose is not None and not stale and velocity_ref != 0.0 and self.monitor.watching(state.stamp):
                _, x, y, orientation = self._pose
                velocity_ref, limited = self.monitor.limit(state.stamp, velocity_ref, x, y,
                                                           rpy_from_quaternion(*orientation)[2])
            out = self.controller.compute(state.stamp, velocity_ref, yaw_rate_ref, state.velocity,
                                          state.yaw_rate, state.pitch, state.pitch_rate, cmd_vel_stale=stale,
                                          hold=self._estimated and self.estimator.calibrating,
                                          command_stamp=self.command.since)
            if self._estimated:
                out = replace(out, pitch_estimated=True, gyro_bias=self.estimator.bias,
                              accelerometer_pitch=self.estimator.accelerometer_pitch)
            if limited:
                out = replace(out, collision_limited=True)
            # The newer of the two stamps, exactly as received (a lockstep simulator compares nanoseconds).
            self._publish(out, max(self._stamps.values(), key=stamp_ns))

    def _publish(self, out: ControlOutput, stamp) -> None:
        command = WheelTorques(left=out.left_torque, right=out.right_torque)
        command.header.stamp = stamp
        command.header.frame_id = "base_link"
        self.pub_torque.publish(command)
        self._last_command = command
        self.pub_state.publish(controller_state_message(out, command.header, self.parameter_revision))
        if out.fallen and not self._reported_fall:
            self._reported_fall = True
            self.get_logger().error(
                f"fallen: |pitch| = {abs(out.pitch):.3f} rad past fall_pitch = {self.cfg['fall_pitch']:g} rad;"
                " zero torque until ~/enable true"
            )


def controller_state_message(out: ControlOutput, header, parameter_revision: int = 0) -> ControllerState:
    msg = ControllerState(header=header, parameter_revision=parameter_revision)
    for name in ControlOutput.__dataclass_fields__:
        if name != "stamp":
            setattr(msg, name, type(getattr(msg, name))(getattr(out, name)))
    return msg


def main(args: list[str] | None = None) -> int:
    return run_node("controller_node", ControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
