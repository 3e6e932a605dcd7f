"""MujocoSimulator: the `Simulator` interface with MuJoCo as the robot's mechanics (no ROS).

Everything a driver does besides the mechanics is the ideal simulator's own code: command admission and
staleness, the torque limit, the world, the IMU's noise/bias/delay and the encoders' counts. Only the
motion, the ideal IMU reading and the wheel loads come from MuJoCo. After each step the multibody state is
mapped onto the ideal model's state vector (pitch and yaw from the chassis orientation, forward speed along
the heading, wheel angles gamma = hinge + pitch), so that odom, ground_truth, sim_status and the world see
the same quantities from either engine.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from twbr_common.params import ConfigError, defaults
from twbr_mujoco.lidar_scene import LidarScene
from twbr_mujoco.model import CHASSIS, LEFT_JOINT, LEFT_TYRE, LEFT_WHEEL, MUJOCO_SPECS, RIGHT_JOINT, RIGHT_TYRE, RIGHT_WHEEL, mjcf
from twbr_mujoco.motor import advance_current
from twbr_sim import dynamics as dyn
from twbr_sim import lidar
from twbr_sim.encoders import J_RATE_LEFT, J_RATE_RIGHT, encoder_sample
from twbr_sim.encoders import N_OUTPUTS as N_ENCODER_OUTPUTS
from twbr_sim.imu import N_READING, RD_ACCEL, RD_GYRO, RD_PITCH, RD_ROLL, RD_YAW
from twbr_sim.robot_params import P_FALL, robot_params
from twbr_sim.scenario import Scenario
from twbr_sim.simulator import SensorSample, Simulator
from twbr_sim.traction import N_OUTPUTS as N_TRACTION_OUTPUTS
from twbr_sim.traction import TF_DEMAND_LEFT, TF_DEMAND_RIGHT, TF_NORMAL_LEFT, TF_NORMAL_RIGHT


def euler_zyx(quat: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of a MuJoCo quaternion (w, x, y, z), body to world, yaw-pitch-roll order."""
    w, x, y, z = quat
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def quat_zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    return np.array([
        cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ])


class MujocoSimulator(Simulator):
    def __init__(self, robot: Mapping[str, Any], settings: dict, scenario: Scenario | None, seed: int) -> None:
        super().__init__(robot_params(robot), settings, scenario, seed)
        if settings["mujoco.contact_time_constant"] < 2.0 * self.h - 1e-12:
            # MuJoCo would clamp it to two steps without a word: the contact would be softer than asked.
            raise ConfigError(
                f"invalid parameter 'mujoco.contact_time_constant' = {settings['mujoco.contact_time_constant']:g}:"
                f" must be at least two physics steps, 2 / physics_rate = {2.0 * self.h:g} s")
        self.model = mujoco.MjModel.from_xml_string(mjcf(robot, settings, self.h))
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._hinge_q = [m.jnt_qposadr[m.joint(j).id] for j in (LEFT_JOINT, RIGHT_JOINT)]
        self._hinge_v = [m.jnt_dofadr[m.joint(j).id] for j in (LEFT_JOINT, RIGHT_JOINT)]
        self._tyres = (m.geom(LEFT_TYRE).id, m.geom(RIGHT_TYRE).id)
        self._wheels = (m.body(LEFT_WHEEL).id, m.body(RIGHT_WHEEL).id)
        self._chassis = m.body(CHASSIS).id
        self._gyro = m.sensor_adr[m.sensor("gyro").id]
        self._accel = m.sensor_adr[m.sensor("accelerometer").id]
        self.slip_speed = settings["mujoco.slip_speed"]
        self.lidar_scene = LidarScene()
        self.roll = 0.0
        self.spin_rates = (0.0, 0.0)  # wheel rates about the axle, absolute (gamma dot) [rad/s]
        s = self.state
        d = self.data
        d.qpos[0:3] = (s[dyn.S_XC], s[dyn.S_YC], robot["wheel_radius"])
        d.qpos[3:7] = quat_zyx(0.0, s[dyn.S_TH], s[dyn.S_PSI])
        self._settle()
        self._read_state()

    def _settle(self, steps: int = 300) -> None:
        """Let the soft contact take the robot's weight, all else held: the run starts on loaded wheels
        (a millimetre-fraction lower than the ideal model's axle), not with a drop onto the floor."""
        m, d = self.model, self.data
        held = d.qpos.copy()
        for _ in range(steps):
            mujoco.mj_step(m, d)
            z, vz = d.qpos[2], d.qvel[2]
            d.qpos[:] = held
            d.qvel[:] = 0.0
            d.qpos[2], d.qvel[2] = z, vz
        d.qvel[:] = 0.0
        d.time = 0.0
        mujoco.mj_forward(m, d)

    def warm_up(self) -> None:
        """Compile the kernels on a throwaway state, then restore this one."""
        saved = (self.data.qpos.copy(), self.data.qvel.copy(), self.state.copy())
        for kernel_call in (lambda: advance_current(self.p, 0.0, 0.0, 0.0, self.h),):
            kernel_call()
        self.data.qpos[:], self.data.qvel[:], self.state[:] = saved
        mujoco.mj_forward(self.model, self.data)

    def advance(self, n_steps: int) -> None:
        m, d, s, p = self.model, self.data, self.state, self.p
        qv = self._hinge_v
        for _ in range(n_steps):
            left, right = self.applied_command()
            i_l, torque_l = advance_current(p, left, s[dyn.S_IL], d.qvel[qv[0]], self.h)
            i_r, torque_r = advance_current(p, right, s[dyn.S_IR], d.qvel[qv[1]], self.h)
            d.ctrl[0] = torque_l
            d.ctrl[1] = torque_r
            x_before, y_before = d.qpos[0], d.qpos[1]
            mujoco.mj_step(m, d)
            s[dyn.S_IL], s[dyn.S_IR] = i_l, i_r
            # Forward travel: the axle's displacement along the heading.
            heading = s[dyn.S_PSI]
            s[dyn.S_X] += (d.qpos[0] - x_before) * math.cos(heading) + (d.qpos[1] - y_before) * math.sin(heading)
            self.step_count += 1
            self._read_pose()
            if abs(s[dyn.S_TH]) > p[P_FALL]:
                self.fallen = True
        mujoco.mj_forward(m, d)  # sensors and contact forces of the state reached
        self._read_state()
        if self.world is not None:
            self.world.advance_to(self.time, (s[dyn.S_XC], s[dyn.S_YC]))

    def _read_pose(self) -> None:
        s, d = self.state, self.data
        self.roll, s[dyn.S_TH], yaw = euler_zyx(d.qpos[3:7])
        # Unwrapped yaw, as the ideal model's.
        s[dyn.S_PSI] += math.remainder(yaw - s[dyn.S_PSI], 2.0 * math.pi)

    def _read_state(self) -> None:
        """The ideal model's state vector from MuJoCo's (after mj_forward)."""
        s, d = self.state, self.data
        self._read_pose()
        roll, pitch, yaw = self.roll, s[dyn.S_TH], s[dyn.S_PSI]
        s[dyn.S_XC], s[dyn.S_YC] = d.qpos[0], d.qpos[1]
        s[dyn.S_XD] = d.qvel[0] * math.cos(yaw) + d.qvel[1] * math.sin(yaw)
        # Body rates (the free joint's angular velocity is in the body frame) -> yaw-pitch-roll Euler rates.
        wy, wz = d.qvel[4], d.qvel[5]
        cr, sr = math.cos(roll), math.sin(roll)
        s[dyn.S_THD] = wy * cr - wz * sr
        s[dyn.S_PSID] = (wy * sr + wz * cr) / max(math.cos(pitch), 1e-6)
        hq, hv = self._hinge_q, self._hinge_v
        s[dyn.S_GL] = d.qpos[hq[0]] + pitch
        s[dyn.S_GR] = d.qpos[hq[1]] + pitch
        self.spin_rates = (d.qvel[hv[0]] + wy, d.qvel[hv[1]] + wy)

    def scan(self) -> np.ndarray:
        """One LiDAR scan started at the current state, cast by MuJoCo's ray tracer from the chassis' own pose
        (lidar_scene.py), with the device's noise and dropouts."""
        s, d = self.state, self.data
        positions, velocities, radii = self.obstacle_arrays()
        ranges = np.empty(int(self.lidar_settings[lidar.LD_BEAMS]))
        self.lidar_scene.cast(self.lidar_settings, d.xpos[self._chassis], d.xmat[self._chassis].reshape(3, 3),
                              s[dyn.S_XD], s[dyn.S_PSID], positions, velocities, radii, ranges)
        lidar.scan_noise(self.lidar_settings, self._lidar_generator, ranges)
        return ranges

    def derivative(self) -> np.ndarray:
        """Not defined for a multibody state: the accelerations the IMU needs come from MuJoCo's sensors."""
        raise NotImplementedError("MujocoSimulator: read the IMU through sense()")

    def ideal_imu(self) -> np.ndarray:
        """The IMU reading without noise (R_* layout): orientation, MuJoCo's gyro and accelerometer."""
        out = np.zeros(N_READING)
        d = self.data
        out[RD_ROLL], out[RD_PITCH], out[RD_YAW] = self.roll, self.state[dyn.S_TH], self.state[dyn.S_PSI]
        out[RD_GYRO:RD_GYRO + 3] = d.sensordata[self._gyro:self._gyro + 3]
        out[RD_ACCEL:RD_ACCEL + 3] = d.sensordata[self._accel:self._accel + 3]
        return out

    def wheel_contacts(self) -> np.ndarray:
        """Per wheel: floor normal force and tangential (friction) force [N], and the contact point's
        sliding speed over the floor [m/s]; zeros for a wheel off the floor. Rows left, right."""
        m, d = self.model, self.data
        out = np.zeros((2, 3))
        force = np.zeros(6)
        velocity = np.zeros(6)
        for k in range(d.ncon):
            contact = d.contact[k]
            for side, tyre in enumerate(self._tyres):
                if tyre not in (contact.geom1, contact.geom2):
                    continue
                mujoco.mj_contactForce(m, d, k, force)
                out[side, 0] += force[0]
                out[side, 1] += math.hypot(force[1], force[2])
                body = self._wheels[side]
                mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, body, velocity, 0)
                arm = contact.pos - d.xpos[body]
                slide = velocity[3:6] + np.cross(velocity[0:3], arm)
                out[side, 2] = max(out[side, 2], math.hypot(slide[0], slide[1]))
        return out

    def sense(self) -> SensorSample:
        if self._sample is not None and self._sample[0] == self.step_count:
            return self._sample[1]
        imu = self.imu_model.read_ideal(self.ideal_imu())
        encoders = np.zeros(N_ENCODER_OUTPUTS)
        encoder_sample(self.p, self._encoder_c, self._encoder_m, self.state, encoders)
        if self._encoder_c[0] == 0.0:  # exact: the wheels' true spin, slip included
            encoders[J_RATE_LEFT], encoders[J_RATE_RIGHT] = self.spin_rates
        contacts = self.wheel_contacts()
        loads = np.zeros(N_TRACTION_OUTPUTS)
        loads[TF_NORMAL_LEFT], loads[TF_NORMAL_RIGHT] = contacts[:, 0]
        loads[TF_DEMAND_LEFT], loads[TF_DEMAND_RIGHT] = contacts[:, 1]
        lifted = slipping = False
        if not self.fallen:
            lifted = bool((contacts[:, 0] <= 0.0).any())
            slipping = bool((contacts[:, 2] > self.slip_speed).any())
        self.traction.add(lifted, slipping)
        sample = SensorSample(imu, encoders, loads, lifted, slipping)
        self._sample = (self.step_count, sample)
        return sample


def mujoco_simulator(robot: dict, settings: dict, scenario: Scenario | None, seed: int) -> MujocoSimulator:
    """A closed_loop engine: MuJoCo with MUJOCO_SPECS' defaults under `settings`."""
    return MujocoSimulator(robot, {**defaults(MUJOCO_SPECS), **settings}, scenario, seed)
