"""Headless closed loop: the simulator core and the controller core exchanging states and commands.

It reproduces what the nodes do in lockstep (the state at step k, the command computed from it applied
until step k+1), without DDS, so the tuner, the unit tests of the step response and batch studies run
the same cores as the node graph, thousands of times faster.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from twbr_common.params import default_of, defaults, validate_all
from twbr_common.timing import Decimator
from twbr_common.wire import (
    detection_read_back,
    heading_speed,
    pitch_yaw_read_back,
    stamp_seconds_of,
    target_velocity_read_back,
)
from twbr_control.cascade import CascadeController, ControlOutput
from twbr_control.collision_monitor import CollisionMonitor
from twbr_control.controller_params import resolve as resolve_controller
from twbr_control.estimator import PitchEstimator, uses_estimator
from twbr_control.state_sync import VelocityCommand
from twbr_sim import dynamics as dyn
from twbr_sim import lidar
from twbr_sim.encoders import J_VELOCITY, J_X, J_Y, J_YAW, J_YAW_RATE
from twbr_sim.robot_params import ROBOT_SPECS, robot_params
from twbr_sim.scenario import Scenario, command_at
from twbr_sim.simulator import SIM_SPECS, Simulator, TractionTally

# (velocity_ref, yaw_rate_ref) at sim time t, given the simulator (for planners that read the state); a planner
# adds the stamp its command applies from (the cascade's command_stamp), else every sample is a new command.
Reference = Callable[[float, Simulator], tuple[float, ...]]
# A robot from (robot parameters by name, simulator settings, scenario, seed): the ideal model by default,
# or another physics engine behind the same interface (twbr_mujoco.physics.MujocoSimulator).
SimulatorFactory = Callable[[dict, dict, "Scenario | None", int], Simulator]


def ideal_simulator(robot: dict, settings: dict, scenario: Scenario | None, seed: int) -> Simulator:
    return Simulator(robot_params(robot), settings, scenario, seed)


@dataclass
class Trace:
    """Per control sample arrays (name: ControlOutput field), plus the robot's path and the wheel torques."""

    t: np.ndarray
    outputs: dict[str, np.ndarray]
    x_c: np.ndarray
    y_c: np.ndarray
    wheel_torque_left: np.ndarray  # delivered by the motors [N·m]
    wheel_torque_right: np.ndarray
    fallen: bool
    pitch_true: np.ndarray  # the body's pitch [rad] (outputs["pitch"] is what the controller used)
    velocity_true: np.ndarray  # the axle's forward speed [m/s]
    yaw_rate_true: np.ndarray  # [rad/s]
    traction: TractionTally

    def __getitem__(self, name: str) -> np.ndarray:
        return self.outputs[name]


def scenario_reference(scenario: Scenario) -> Reference:
    return lambda t, _sim: command_at(scenario, t)


def run_closed_loop(
    duration: float,
    reference: Reference,
    control: Mapping[str, Any] | None = None,
    robot: Mapping[str, Any] | None = None,
    sim: Mapping[str, Any] | None = None,
    scenario: Scenario | None = None,
    seed: int = 0,
    stop_on_fall: bool = True,
    stop: Callable[[Simulator], bool] | None = None,
    engine: SimulatorFactory = ideal_simulator,
) -> Trace:
    """Run the cores for `duration` seconds of sim time, or until `stop(simulator)` (checked after each
    control step, as a simulator ending a run on its target would); settings default to the tables."""
    control_cfg = resolve_controller(control)
    sim_cfg = validate_all(SIM_SPECS, {**defaults(SIM_SPECS), **(sim or {})})
    sim_cfg["publish_rate"] = control_cfg["rate"]
    simulator = engine(validate_all(ROBOT_SPECS, {**defaults(ROBOT_SPECS), **(robot or {})}), sim_cfg, scenario,
                       seed)
    controller = CascadeController(control_cfg)
    estimator = PitchEstimator(control_cfg)
    estimate = uses_estimator(control_cfg["pitch_source"], simulator.imu_model.raw)
    n = round(duration * control_cfg["rate"]) + 1
    rows: list[ControlOutput] = []
    path = np.empty((n, 7))
    for k in range(n):
        t = simulator.time
        stamp = stamp_seconds_of(simulator.stamp_ns)  # what the controller reads (twbr_common.wire)
        s = simulator.state
        sample = simulator.sense()
        reading, odom = sample.imu, sample.encoders  # what the imu and odom messages carry
        velocity, yaw_rate = odom[J_VELOCITY], odom[J_YAW_RATE]
        pitch, _ = pitch_yaw_read_back(reading.roll, reading.pitch, reading.yaw)  # from the imu's quaternion
        pitch_rate = reading.angular_velocity[1]
        if estimate:
            pitch, pitch_rate = estimator.update(stamp, pitch_rate, reading.linear_acceleration[0],
                                                 reading.linear_acceleration[2], velocity)
            velocity = estimator.velocity
        # (v, omega[, the sample from which they apply, None before any command: cmd_vel stale, as in the graph])
        v_ref, w_ref, *since = reference(t, simulator)
        out = controller.compute(stamp, v_ref, w_ref, velocity, yaw_rate, pitch, pitch_rate,
                                 cmd_vel_stale=bool(since) and since[0] is None,
                                 hold=estimate and estimator.calibrating, command_stamp=since[0] if since else stamp)
        if estimate:
            out = replace(out, pitch_estimated=True, gyro_bias=estimator.bias,
                          accelerometer_pitch=estimator.accelerometer_pitch)
        rows.append(out)
        path[k, :2] = s[dyn.S_XC], s[dyn.S_YC]
        path[k, 2:4] = simulator.wheel_torques()
        path[k, 4:] = s[dyn.S_TH], s[dyn.S_XD], s[dyn.S_PSID]
        if k == n - 1 or (stop_on_fall and simulator.fallen) or (stop is not None and stop(simulator)):
            path = path[: k + 1]
            break
        simulator.offer_command(t, out.left_torque, out.right_torque)
        simulator.advance(simulator.steps_per_publish)
    names = [f.name for f in fields(ControlOutput)]
    outputs = {name: np.array([getattr(r, name) for r in rows], dtype=float) for name in names}
    return Trace(outputs["stamp"], outputs, path[:, 0], path[:, 1], path[:, 2], path[:, 3], simulator.fallen,
                 path[:, 4], path[:, 5], path[:, 6], simulator.traction)


class PlannerReference:
    """The APF planner core as the reference source, fed from the simulator's world at `rate` [Hz] (the
    planner node's default when None). Its settings are `planner` over what the simulator's scenario pins,
    so it is built at the first step, when the simulator is known. The controller node's collision monitor
    (its settings from `control`, the defaults when None) limits the speed at every sample, on the world's
    obstacles of the last planning instant, as the node has them from the world's last message.

    `perception` "lidar": as the runner's graph with tracker_node (its parameters `tracker`), the planner
    and the monitor take the obstacles the tracker core makes of each of the simulator's scans, and the
    planner follows the target its filter makes of the detector's looks (the target's start as its prior);
    what it saw and how well it tracked stay in `self.perception` (None on the truth)."""

    def __init__(self, planner: Mapping[str, Any] | None = None, rate: float | None = None, log: list | None = None,
                 control: Mapping[str, Any] | None = None, perception: str = "truth",
                 tracker: Mapping[str, Any] | None = None) -> None:
        from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
        from twbr_planner.planner_params import resolve as resolve_planner

        resolve_planner(planner)  # refused here, before a run starts, when invalid on its own
        self.planner = planner
        self.rate = default_of(PLANNER_NODE_SPECS, "rate") if rate is None else rate
        self.log = log
        self.due = Decimator(self.rate)
        # Each plan takes effect from the next state on, as controller_node takes a cmd_vel: the same class.
        # No message is lost here, so the command never times out.
        self.command = VelocityCommand(timeout=math.inf)
        self.core: Any = None
        self.monitor = CollisionMonitor(resolve_controller(control))
        self.perception = LidarPerception(tracker) if perception == "lidar" else None

    def __call__(self, t: float, sim: Simulator) -> tuple[float, float, float | None]:
        from twbr_planner.apf import Obstacles
        from twbr_planner.planner import ApfPlanner
        from twbr_planner.planner_params import resolve as resolve_planner

        if self.core is None:
            self.core = ApfPlanner(resolve_planner(self.planner, sim.scenario), self.rate)
        stamp = stamp_seconds_of(sim.stamp_ns)  # the nodes' time: the state's stamp read back (twbr_common.wire)
        v_ref, w_ref, never_commanded = self.command.at(stamp)
        seeing = self.perception
        if seeing is not None:
            seeing.sense(stamp, sim, self.monitor)
        odom = sim.sense().encoders  # the pose and speed odom carries, as planner_node gets them
        _, yaw = odom_orientation(sim)
        if self.due.due(stamp):
            world = sim.world
            if seeing is not None:
                target, obstacles = seeing.target(sim), seeing.obstacles_at(stamp)
            else:
                target = world_target(sim)
                listed = world.obstacles() if world else []
                obstacles = (Obstacles.of([(o.id, o.x, o.y, o.radius, o.vx, o.vy) for o in listed])
                             if world else Obstacles.empty())
                if listed:
                    self.monitor.obstacles(stamp, np.array([(o.id, o.x, o.y, o.vx, o.vy, o.radius) for o in listed]))
            out = self.core.step(stamp, odom[J_X], odom[J_Y], yaw, odom[J_VELOCITY], target, obstacles)
            if self.log is not None:
                self.log.append(out)
            self.command.offer(stamp, out.velocity_cmd, out.yaw_rate_cmd)
        if not never_commanded:
            v_ref, _ = self.monitor.limit(stamp, v_ref, odom[J_X], odom[J_Y], yaw)
        return v_ref, w_ref, None if never_commanded else self.command.since


def odom_orientation(sim: Simulator) -> tuple[float, float]:
    """(pitch, yaw) [rad] as the nodes read them from odom's quaternion: the true pitch and odom's yaw."""
    return pitch_yaw_read_back(0.0, sim.state[dyn.S_TH], sim.sense().encoders[J_YAW])


def world_target(sim: Simulator) -> Any:
    """The world's target as planner_node reads its message (heading in a quaternion, and a speed)."""
    from twbr_planner.planner import Target

    state = sim.world.target() if sim.world is not None else None
    if state is None:
        return None
    return Target(state.x, state.y, *target_velocity_read_back(state.heading, state.speed))


class LidarPerception:
    """What tracker_node makes of a simulator's scan and target detector, on the scalar cores (the tracker's
    and target filter's classes), with a LaserScan's rounding: float32 ranges and angle fields; and the
    tracker judged against the world at every scan (`judge`: evaluation.JUDGE_LAYOUT's sums, as a graph
    run's metrics.json and the batch engine's result rows have them)."""

    def __init__(self, tracker: Mapping[str, Any] | None) -> None:
        from twbr_tracker.evaluation import N_JUDGE
        from twbr_tracker.target import MISSION_PRIOR_STD, TARGET_SPECS, TargetFilter
        from twbr_tracker.tracker import TRACKER_SPECS, Tracker

        specs = (*TRACKER_SPECS, *TARGET_SPECS)
        self.cfg = validate_all(specs, {**defaults(specs), **(tracker or {}), "target.prior_std": MISSION_PRIOR_STD})
        self.tracker = Tracker(self.cfg)
        self.judge = np.zeros(N_JUDGE)
        self._born = np.tile([-1.0, 0.0], (int(self.cfg["tracking.max_tracks"]), 1))  # judge_lists' memories
        self._last_track: np.ndarray | None = None
        self.filter: TargetFilter | None = None  # built at the first look: its prior is where the target starts
        self.rows = np.zeros((0, 6))  # the last scan's obstacles: id, x, y, vx, vy, radius
        self.stamp = 0.0
        self.fused: Any = None  # the last look's planner Target
        self._scan_due: Decimator | None = None
        self._look_due: Decimator | None = None

    def sense(self, t: float, sim: Simulator, monitor: CollisionMonitor) -> None:
        """The scan and the look due at t, as sim_node publishes them and tracker_node takes them."""
        from twbr_planner.planner import Target
        from twbr_tracker.evaluation import GATE, SETTLE, judge_lists
        from twbr_tracker.target import TargetFilter

        if self._scan_due is None:
            self._scan_due = Decimator(sim.lidar_rate)
            self._look_due = Decimator(sim.target_sensor_rate) if sim.target_sensor_rate > 0.0 else None
        odom = sim.sense().encoders
        pitch, yaw = odom_orientation(sim)
        if self._scan_due.due(t):
            s = sim.lidar_settings
            positions, velocities, radii = sim.obstacle_arrays()  # the scan's and the judge's
            ranges = sim.scan((positions, velocities, radii)).astype(np.float32).astype(np.float64)
            self.rows = self.tracker.step_rows(t, ranges, float(np.float32(s[lidar.LD_ANGLE_MIN])),
                                               float(np.float32(s[lidar.LD_ANGLE_INCREMENT])),
                                               float(np.float32(1.0 / sim.lidar_rate / s[lidar.LD_BEAMS])), odom[J_X],
                                               odom[J_Y], yaw, odom[J_VELOCITY], odom[J_YAW_RATE], pitch)
            self.stamp = t
            monitor.obstacles(t, self.rows)
            if self._last_track is None:
                self._last_track = np.full(len(radii), -1.0)
            state = sim.state
            judge_lists(self.judge, self._born, self._last_track, t, self.rows, len(self.rows), positions, velocities,
                        radii, state[dyn.S_XC], state[dyn.S_YC], s[lidar.LD_RANGE_MAX], GATE, SETTLE)
        if self._look_due is not None and sim.world is not None and self._look_due.due(t):
            if self.filter is None:
                start = sim.world.target()
                self.filter = TargetFilter({**self.cfg, "target.prior_x": start.x, "target.prior_y": start.y})
            seen = sim.target_detection()
            if seen is not None:  # range and bearing as tracker_node reads them from the PoseArray
                self.filter.measure(t, *detection_read_back(*seen), odom[J_X], odom[J_Y], yaw, pitch)
            estimate = self.filter.estimate(t)  # sent as the target's odometry, read by the planner
            velocity = target_velocity_read_back(*heading_speed(estimate.vx, estimate.vy))
            self.fused = Target(estimate.x, estimate.y, *velocity)

    def target(self, sim: Simulator) -> Any:
        """The fused target (the world's where the robot has no detector)."""
        return world_target(sim) if self._look_due is None else self.fused

    def obstacles_at(self, t: float) -> Any:
        """The last scan's obstacles moved along their velocities to t, as planner_node moves them."""
        from twbr_planner.apf import Obstacles

        return Obstacles.from_rows(self.rows, t - self.stamp)
