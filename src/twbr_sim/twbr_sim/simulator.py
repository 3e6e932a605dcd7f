"""The simulated robot side of the graph, without ROS: dynamics + motors + sensors + world + command admission.

sim_node is a thin adapter around this class; tests and headless runs drive it directly. Time is kept
as an integer count of physics steps so that sim time never drifts.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from twbr_common.guard import INPUT_SPECS, TORQUE_LIMIT, InputGuard, Verdict, future_tolerance
from twbr_common.params import ConfigError, ParamSpec
from twbr_common.wire import step_nanoseconds
from twbr_sim import dynamics as dyn
from twbr_sim import lidar, target_sensor
from twbr_sim.encoders import ENCODER_SPECS, J_RATE_LEFT, J_RATE_RIGHT, encoder_sample
from twbr_sim.encoders import N_OUTPUTS as N_ENCODER_OUTPUTS
from twbr_sim.encoders import new_memory as new_encoder_memory
from twbr_sim.encoders import settings_vector as encoder_vector
from twbr_sim.imu import IMU_SPECS, ImuModel, ImuReading
from twbr_sim.lidar import LIDAR_SPECS
from twbr_sim.noise import new_generator
from twbr_sim.robot_params import P_R, P_ROBOT_RADIUS, wheel_torque_limit
from twbr_sim.scenario import Scenario
from twbr_sim.target_sensor import TARGET_SENSOR_SPECS
from twbr_sim.traction import N_OUTPUTS as N_TRACTION_OUTPUTS
from twbr_sim.traction import TRACTION_SPECS, traction_flags, wheel_loads
from twbr_sim.world import Assessment, World

# What a batch study may set of the robot's sensors and traction (SIM_SPECS has them all).
SENSOR_SPECS: tuple[ParamSpec, ...] = (*IMU_SPECS, *ENCODER_SPECS, *TRACTION_SPECS, *LIDAR_SPECS,
                                       *TARGET_SENSOR_SPECS)

SIM_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("physics_rate", 1000.0, "rate of the RK4 integration of dynamics and motors", "Hz", 10.0, 100000.0),
    ParamSpec(
        "publish_rate", 200.0,
        "rate of odom, imu, joint_states and clock; in lockstep, the rate of state/command exchanges"
        " (set it to the controller's rate); must divide physics_rate", "Hz", 1.0, 10000.0,
    ),
    ParamSpec("mode", "lockstep", "lockstep: step only on the command computed from the last state;"
              " realtime: step on a wall-clock timer", choices=("lockstep", "realtime")),
    ParamSpec("real_time_factor", 1.0, "realtime mode: simulated seconds per wall-clock second", "", 0.01, 100.0),
    ParamSpec("lockstep_timeout", 0.5, "lockstep: wall time to wait for the command before stepping without"
              " it (counted as a timeout)", "s", 0.001, 60.0),
    ParamSpec("wait_for_first_command", True, "lockstep: hold sim time at 0 until the first command arrives,"
              " so a controller started later finds the robot upright"),
    ParamSpec("lockstep_planner_rate", 0.0, "lockstep: also hold every 1/rate s of sim time until planner_state"
              " stamped with that state arrives (the runner sets it to the planner's rate; 0: do not wait)", "Hz",
              0.0, 1000.0),
    ParamSpec("lockstep_commands", False, "lockstep: where the scenario's scripted cmd_vel profile changes, or its"
              " command has not been heard for 0.25 s, also hold the state until the command (a Twist) is seen on"
              " cmd_vel: a command_player starved on a loaded host still steps the robot at the profile's time and"
              " keeps the controller's cmd_vel fresh (the runner sets it for scripted scenarios)"),
    ParamSpec("wait_for_subscribers", 0, "publish nothing until odom has this many matched subscriptions (a"
              " runner sets it so that its recorder and controller both see t = 0)", "", 0, 1000),
    ParamSpec("command_timeout", 0.1, "a wheel_torque_cmd older than this (sim time) is stale: zero torque", "s",
              0.001, 10.0),
    ParamSpec("duration", -1.0, "sim time after which the node stops by itself; 0 runs until stopped;"
              " negative: the scenario's own duration (no scenario: until stopped)", "s", -1.0, 1e7),
    ParamSpec("scenario", "", "scenario file: a path, or a name in share/twbr_config/config/scenarios;"
              " empty: the robot alone at the origin"),
    ParamSpec("host_world", True, "publish the scenario's target and obstacles (false when world_node runs)"),
    ParamSpec("seed", -1, "seed of the target's turns and the IMU noise; -1 takes the scenario's", "", -1,
              2**31 - 1),
    ParamSpec("clock_rate", 0.0, "rate of /clock; 0: with every state (publish_rate). Every node on sim time"
              " handles each /clock message: a lower rate frees CPU, at the cost of a coarser node clock", "Hz",
              0.0, 10000.0),
    ParamSpec("world_rate", 20.0, "rate of target, obstacles and world_status", "Hz", 0.1, 1000.0),
    ParamSpec("marker_rate", 5.0, "rate of the RViz world markers", "Hz", 0.1, 100.0),
    ParamSpec("tf_rate", 50.0, "rate of the odom -> base_link transform", "Hz", 0.1, 1000.0),
    ParamSpec("odom_frame", "odom", "fixed frame of odom, target and obstacles"),
    ParamSpec("base_frame", "base_link", "robot frame (axle centre, pitched with the body)"),
    *SENSOR_SPECS,
    *INPUT_SPECS,
)


@dataclass
class SensorSample:
    """What the robot's sensors report with one published state (sense())."""

    imu: ImuReading
    encoders: np.ndarray  # encoders.OUTPUT_LAYOUT: joint angles and rates, odometry pose and twist
    loads: np.ndarray  # traction.OUTPUT_LAYOUT: normal forces and friction demands [N]
    wheel_lifted: bool
    wheel_slipping: bool


@dataclass
class TractionTally:
    """Published states with a wheel lifted / slipping, and how often each began."""

    lifted_samples: int = 0
    slipping_samples: int = 0
    lift_events: int = 0
    slip_events: int = 0
    lifted: bool = False
    slipping: bool = False

    def add(self, lifted: bool, slipping: bool) -> None:
        self.lift_events += lifted and not self.lifted
        self.slip_events += slipping and not self.slipping
        self.lifted_samples += lifted
        self.slipping_samples += slipping
        self.lifted, self.slipping = lifted, slipping


@dataclass(frozen=True)
class CommandResult:
    verdict: Verdict
    saturated: bool = False


def steps_per_publish(physics_rate: float, publish_rate: float) -> int:
    ratio = physics_rate / publish_rate
    n = round(ratio)
    if n < 1 or abs(ratio - n) > 1e-9 * ratio:
        raise ConfigError(
            f"invalid parameter 'publish_rate' = {publish_rate:g}: must divide physics_rate"
            f" = {physics_rate:g} Hz into a whole number of steps"
        )
    return n


class Simulator:
    def __init__(self, robot: np.ndarray, settings: dict, scenario: Scenario | None, seed: int) -> None:
        self.p = robot
        self.h = 1.0 / settings["physics_rate"]
        self.step_ns = step_nanoseconds(settings["physics_rate"])
        self.steps_per_publish = steps_per_publish(settings["physics_rate"], settings["publish_rate"])
        self.torque_limit = wheel_torque_limit(robot)
        # The simulator's clock is sim time: a command stamped ahead of it comes from another clock.
        self.guard = InputGuard(settings["command_timeout"], limit=TORQUE_LIMIT,
                                future_tolerance=future_tolerance(settings["future_tolerance"], sim_time=True))
        self.scenario = scenario
        self.world = World(scenario, robot[P_ROBOT_RADIUS], seed) if scenario is not None else None
        self.imu_model = ImuModel(settings, seed, settings["publish_rate"])
        self._encoder_c = encoder_vector(settings, settings["publish_rate"])
        self._encoder_m = new_encoder_memory(self._encoder_c)
        self.friction = settings["traction.friction"]
        self.lidar_rate = settings["lidar.rate"]
        self.lidar_settings = lidar.settings_vector(settings)  # lidar.SETTINGS_LAYOUT
        self._lidar_generator = new_generator(seed, lidar.LIDAR_STREAM)
        self.target_sensor_rate = settings["target_sensor.rate"]
        self._target_s = target_sensor.settings_vector(settings)
        self._target_generator = new_generator(seed, target_sensor.TARGET_SENSOR_STREAM)
        self.traction = TractionTally()
        self._sample: tuple[int, SensorSample] | None = None
        sc = scenario
        self.state = dyn.initial_state(
            sc.start_x if sc else 0.0, sc.start_y if sc else 0.0,
            sc.start_yaw if sc else 0.0, sc.start_pitch if sc else 0.0,
        )
        self._work = dyn.new_work()
        self.step_count = 0
        self._command = (0.0, 0.0)
        self.torque_saturated = False
        self.fallen = False
        self.lockstep_timeouts = 0

    def warm_up(self) -> None:
        """Load the compiled kernels now, on a copy, so the first published state is on time."""
        twin = copy.deepcopy(self)
        twin.advance(2 * twin.steps_per_publish)
        twin.sense()
        twin.wheel_torques()
        twin.assess()
        if twin.lidar_rate > 0.0:
            twin.scan()
        if twin.target_sensor_rate > 0.0:
            twin.target_detection()

    def obstacle_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The world's obstacles now as the sensors' kernels take them: positions (n, 2) [m], velocities
        (n, 2) [m/s], radii (n,) [m]."""
        obstacles = self.world.obstacles() if self.world is not None else []
        return (np.array([(o.x, o.y) for o in obstacles], dtype=float).reshape(-1, 2),
                np.array([(o.vx, o.vy) for o in obstacles], dtype=float).reshape(-1, 2),
                np.array([o.radius for o in obstacles], dtype=float))

    def scan(self, obstacles: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """One LiDAR scan started at the current state (lidar.py): ranges [m] by beam, the device's noise
        and dropouts included, REP 117's -inf / +inf outside its range. `obstacles`: obstacle_arrays() now,
        if the caller has them already."""
        s = self.state
        positions, velocities, radii = self.obstacle_arrays() if obstacles is None else obstacles
        ranges = np.empty(int(self.lidar_settings[lidar.LD_BEAMS]))
        lidar.cast_scan(self.lidar_settings, s[dyn.S_XC], s[dyn.S_YC], s[dyn.S_PSI], s[dyn.S_TH], s[dyn.S_XD],
                        s[dyn.S_PSID], self.p[P_R], positions, velocities, radii, ranges)
        lidar.scan_noise(self.lidar_settings, self._lidar_generator, ranges)
        return ranges

    def target_detection(self) -> tuple[float, float] | None:
        """The target detector's measurement at the current state (target_sensor.py): (range [m], bearing
        [rad] from the heading), or None when it does not see the target (none, out of view, hidden, dropped)."""
        target = self.world.target() if self.world is not None else None
        if target is None:
            return None
        s = self.state
        positions, _velocities, radii = self.obstacle_arrays()
        out = np.empty(2)
        if not target_sensor.measure_target(self._target_s, self._target_generator, s[dyn.S_XC], s[dyn.S_YC],
                                            s[dyn.S_PSI], s[dyn.S_TH], target.x, target.y, positions, radii, out):
            return None
        return float(out[0]), float(out[1])

    @property
    def ideal_sensors(self) -> bool:
        """No sensor realism at all: the imu and odom report the true state."""
        c = self.imu_model.c
        return not self.imu_model.raw and not c[1:].any() and self._encoder_c[0] == 0.0

    @property
    def time(self) -> float:
        return self.step_count * self.h

    @property
    def stamp_ns(self) -> int:
        """The current state's stamp [ns], as sim_node publishes it."""
        return self.step_count * self.step_ns

    def offer_command(self, stamp: float, left: float, right: float) -> CommandResult:
        """Admit a wheel_torque_cmd; NaN/inf, absurd, unstamped and out-of-order ones never reach the motors."""
        verdict = self.guard.offer(stamp, (left, right), self.time)
        if verdict is not Verdict.ACCEPTED:
            return CommandResult(verdict)
        lim = self.torque_limit
        clipped = (min(max(left, -lim), lim), min(max(right, -lim), lim))
        self.torque_saturated = clipped != (left, right)
        self._command = clipped
        return CommandResult(verdict, self.torque_saturated)

    @property
    def command_stale(self) -> bool:
        return self.guard.is_stale(self.time)

    def applied_command(self) -> tuple[float, float]:
        """The torque command the motor drivers get now: the last admitted one, or zero when stale."""
        return (0.0, 0.0) if self.command_stale else self._command

    def advance(self, n_steps: int) -> None:
        """Integrate n_steps physics steps; a fallen robot lies still (no ground contact is modelled)."""
        # Staleness only grows with time: if the command is stale now or still fresh at the last step, one
        # command holds for the whole block and one kernel call steps it; otherwise step by step.
        last_step_time = (self.step_count + n_steps - 1) * self.h
        block = n_steps if self.command_stale or not self.guard.is_stale(last_step_time) else 1
        for _ in range(n_steps // block):
            if not self.fallen:
                left, right = self.applied_command()
                self.fallen = dyn.advance_upright(self.p, self.state, left, right, self.h, block, self._work)
            self.step_count += block
        if self.world is not None:
            self.world.advance_to(self.time, (self.state[dyn.S_XC], self.state[dyn.S_YC]))

    def derivative(self) -> np.ndarray:
        if self.fallen:
            return np.zeros(dyn.N_STATE)
        left, right = self.applied_command()
        return dyn.state_derivative(self.p, self.state, left, right)

    def sense(self) -> SensorSample:
        """The sensors' reading of the current state: taken once per state (the sensors have memory: delay,
        bias walk, encoder counts), so asking again at the same step returns the same sample."""
        if self._sample is not None and self._sample[0] == self.step_count:
            return self._sample[1]
        ds = self.derivative()
        imu = self.imu_model.read(self.p, self.state, ds)
        encoders = np.zeros(N_ENCODER_OUTPUTS)
        encoder_sample(self.p, self._encoder_c, self._encoder_m, self.state, encoders)
        loads = np.zeros(N_TRACTION_OUTPUTS)
        lifted = slipping = False
        if not self.fallen:
            wheel_loads(self.p, self.state, ds, loads)
            # bool(): interpreted (TWBR_JIT=off) the kernel's comparisons are numpy bools, which a message's
            # bool field refuses
            lifted, slipping = (bool(flag) for flag in traction_flags(loads, self.friction))
        self.traction.add(lifted, slipping)
        sample = SensorSample(imu, encoders, loads, lifted, slipping)
        self._sample = (self.step_count, sample)
        return sample

    def imu(self) -> ImuReading:
        return self.sense().imu

    def wheel_torques(self) -> tuple[float, float]:
        return dyn.wheel_torques(self.p, self.state)

    def wheel_rates(self) -> tuple[float, float]:
        """The joint rates the encoders report now [rad/s]."""
        e = self.sense().encoders
        return float(e[J_RATE_LEFT]), float(e[J_RATE_RIGHT])

    def assess(self) -> Assessment | None:
        if self.world is None:
            return None
        return self.world.assess(self.state[dyn.S_XC], self.state[dyn.S_YC])
