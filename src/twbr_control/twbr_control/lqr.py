"""LQR gains for the balance and yaw loops, designed at start-up from the robot's parameters (robot.yaml).

The model is the dynamics' own equations (twbr_sim.dynamics.mechanical_accelerations, one implementation)
linearised about upright at rest, without the motors' electrical lag (its pole, 1500 1/s, is far above the
loops'); it is discretised at the control rate with a zero-order hold, as the controller's commands are
held for one period. Balance: state (integral of the speed error, speed error, pitch - pitch_offset, pitch
rate), input the common wheel torque. Yaw: state (integral of the yaw-rate error, yaw-rate error), input
the differential torque. The integrals make the loops track v_ref and omega_ref without a steady error
(friction, a miscalibrated pitch offset).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from twbr_common.params import ConfigError, ParamSpec

LQR_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("lqr.q_position", 454.9, "LQR weight on the integral of the speed error (the position lag)", "1/m²",
              0.0, 1e6),
    ParamSpec("lqr.q_velocity", 0.9986, "LQR weight on the speed error", "s²/m²", 0.0, 1e6),
    ParamSpec("lqr.q_pitch", 0.997, "LQR weight on the pitch", "1/rad²", 0.0, 1e6),
    ParamSpec("lqr.q_pitch_rate", 2.79, "LQR weight on the pitch rate", "s²/rad²", 0.0, 1e6),
    ParamSpec("lqr.setpoint_weight", 0.3519, "weight b of v_ref in the speed term (b*v_ref - v), as the cascade's: b < 1"
              " asks for less roll-back and overshoot on a step; the integral acts on the full error", "", 0.0, 1.0),
    ParamSpec("lqr.r_torque", 1.0, "LQR weight on each wheel's common torque", "1/(N·m)²", 0.0, 1e6,
              low_open=True),
    ParamSpec("lqr.q_heading", 1.197, "LQR weight on the integral of the yaw-rate error (the heading lag)",
              "1/rad²", 0.0, 1e6),
    ParamSpec("lqr.q_yaw_rate", 2.879, "LQR weight on the yaw-rate error", "s²/rad²", 0.0, 1e6),
    ParamSpec("lqr.r_differential", 1.0, "LQR weight on the differential torque", "1/(N·m)²", 0.0, 1e6,
              low_open=True),
    ParamSpec("lqr.robot_file", "", "robot.yaml whose sim_node section the LQR gains are designed for; empty:"
              " the installed config/robot.yaml"),
)
GAIN_NAMES = ("position", "velocity", "pitch", "pitch_rate", "heading", "yaw_rate")


def linear_models(robot: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B) of the balance model on (x, v, pitch, pitch rate) per wheel's torque, and of the yaw model
    on (heading, yaw rate) per differential torque (continuous time)."""
    from twbr_sim import dynamics as dyn
    from twbr_sim.robot_params import D_D_2R, D_YAW_DAMPING, D_YAW_INERTIA0, robot_params

    p = robot_params(robot)

    def f(z: np.ndarray, torque: float) -> np.ndarray:
        acc = dyn.mechanical_accelerations(p, z[1], z[2], z[3], 0.0, torque, torque)
        return np.array([z[1], acc[0], z[3], acc[1]])

    eps = 1e-6
    zero = np.zeros(4)
    a = np.column_stack([(f(zero + eps * e, 0.0) - f(zero - eps * e, 0.0)) / (2 * eps) for e in np.eye(4)])
    b = ((f(zero, eps) - f(zero, -eps)) / (2 * eps))[:, None]
    inertia = p[D_YAW_INERTIA0]
    a_yaw = np.array([[0.0, 1.0], [0.0, -p[D_YAW_DAMPING] / inertia]])
    b_yaw = np.array([[0.0], [2.0 * p[D_D_2R] / inertia]])  # right = common + u, left = common - u
    return a, b, a_yaw, b_yaw


def _dlqr(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: float, period: float) -> np.ndarray:
    import scipy.linalg
    import scipy.signal

    ad, bd, *_ = scipy.signal.cont2discrete((a, b, np.eye(len(a)), np.zeros((len(a), 1))), period, "zoh")
    rr = np.array([[r]])
    p = scipy.linalg.solve_discrete_are(ad, bd, q, rr)
    return np.linalg.solve(rr + bd.T @ p @ bd, bd.T @ p @ ad)[0]


def design(settings: Mapping[str, Any], robot: Mapping[str, Any] | None = None) -> dict[str, float]:
    """The six gains (GAIN_NAMES) for the controller's settings (rate, lqr.*), on `robot` or lqr.robot_file's.
    The control law is u = -K z: common = -(k_position ∫e_v + k_velocity e_v + k_pitch (pitch - offset) +
    k_pitch_rate pitch_rate), differential = -(k_heading ∫e_w + k_yaw_rate e_w), e = measured - reference."""
    s = settings
    from twbr_sim.robot_params import robot_from_file

    robot = robot_from_file(s["lqr.robot_file"], "lqr.robot_file") if robot is None else robot
    a, b, a_yaw, b_yaw = linear_models(robot)
    period = 1.0 / s["rate"]
    k = _dlqr(a, b, np.diag([s["lqr.q_position"], s["lqr.q_velocity"], s["lqr.q_pitch"], s["lqr.q_pitch_rate"]]),
              s["lqr.r_torque"], period)
    k_yaw = _dlqr(a_yaw, b_yaw, np.diag([s["lqr.q_heading"], s["lqr.q_yaw_rate"]]), s["lqr.r_differential"], period)
    gains = (*k, *k_yaw)
    if not all(np.isfinite(gains)):
        raise ConfigError("the LQR weights (lqr.*) give no stabilising gains for this robot")
    return dict(zip(GAIN_NAMES, (float(g) for g in gains), strict=True))
