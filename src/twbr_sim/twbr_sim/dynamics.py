"""Nonlinear TWBR dynamics with a DC motor and current-loop driver per wheel (dynamics.md).

One implementation serves every user: `rk4_step` advances one robot in place and is compiled with
numba, so the simulator node calls it at 1 kHz, `step_batch` loops the very same kernel over a leading
robot axis in parallel for batch studies, and the benchmarks time both. Nothing here allocates per step.

State vector (S_* indices): forward travel x, its rate, pitch theta, its rate, yaw psi, its rate, the
axle centre's position (x_c, y_c) in odom, the wheel angles gamma_L, gamma_R, and the two armature
currents. The wheel torque is the motor's, N k i, never the command.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel, parallel_kernel, prange
from twbr_common.layout import Layout
from twbr_sim.robot_params import (
    D_A,
    D_C2,
    D_CA2_R,
    D_D_2R,
    D_DD,
    D_HALF_D,
    D_INV_LA,
    D_INV_NK,
    D_INV_R,
    D_MGL,
    D_ML,
    D_NK,
    D_YAW_DAMPING,
    D_YAW_INERTIA0,
    P_CA,
    P_D,
    P_FALL,
    P_G,
    P_I1,
    P_I2,
    P_I3,
    P_IMAX,
    P_J,
    P_K,
    P_KI,
    P_KM,
    P_L,
    P_LA,
    P_MB,
    P_MW,
    P_N,
    P_R,
    P_RA,
    P_VMAX,
)

STATE_NAMES = (
    "x", "x_dot", "pitch", "pitch_rate", "yaw", "yaw_rate",
    "x_c", "y_c", "wheel_angle_left", "wheel_angle_right", "current_left", "current_right",
)
STATE_LAYOUT = Layout(STATE_NAMES)
S_X = STATE_LAYOUT["x"]
S_XD = STATE_LAYOUT["x_dot"]
S_TH = STATE_LAYOUT["pitch"]
S_THD = STATE_LAYOUT["pitch_rate"]
S_PSI = STATE_LAYOUT["yaw"]
S_PSID = STATE_LAYOUT["yaw_rate"]
S_XC = STATE_LAYOUT["x_c"]
S_YC = STATE_LAYOUT["y_c"]
S_GL = STATE_LAYOUT["wheel_angle_left"]
S_GR = STATE_LAYOUT["wheel_angle_right"]
S_IL = STATE_LAYOUT["current_left"]
S_IR = STATE_LAYOUT["current_right"]
N_STATE = len(STATE_LAYOUT)
# Rows of the per-robot work array rk4_step needs: k1..k4 and the trial state.
WORK_ROWS = 5

# RK4's real-axis stability limit is h*lambda ~ 2.785; sub-step well inside it.
RK4_SAFE_H_LAMBDA = 2.0

_jit = kernel


@_jit
def mechanical_accelerations(p, x_dot, pitch, pitch_rate, yaw_rate, torque_left, torque_right):
    """(x_ddot, pitch_ddot, yaw_ddot) of the 3-DOF model for given wheel torques [N*m]."""
    s = math.sin(pitch)
    c = math.cos(pitch)
    dd = p[D_DD]
    a = p[D_A]
    ml = p[D_ML]
    b = ml * c
    c2 = p[D_C2]
    slip = x_dot * p[D_INV_R] - pitch_rate
    torque_sum = torque_left + torque_right
    rhs_x = torque_sum * p[D_INV_R] - p[D_CA2_R] * slip + ml * (yaw_rate * yaw_rate + pitch_rate * pitch_rate) * s
    rhs_th = -torque_sum + 2.0 * p[P_CA] * slip - dd * yaw_rate * yaw_rate * s * c + p[D_MGL] * s
    inv_det = 1.0 / (a * c2 - b * b)
    x_ddot = (c2 * rhs_x - b * rhs_th) * inv_det
    pitch_ddot = (a * rhs_th - b * rhs_x) * inv_det
    yaw_inertia = p[D_YAW_INERTIA0] - dd * s * s
    yaw_ddot = (
        p[D_D_2R] * (torque_right - torque_left)
        - p[D_YAW_DAMPING] * yaw_rate
        - (ml * x_dot - 2.0 * dd * pitch_rate * c) * yaw_rate * s
    ) / yaw_inertia
    return x_ddot, pitch_ddot, yaw_ddot


@_jit
def driver_voltage(p, torque_cmd, current, relative_speed):
    """Motor-driver current loop: the armature voltage [V] that makes the motor deliver torque_cmd.

    i_ref = T_cmd / (N k) limited to +-I_max; V = R i_ref + back-EMF feed-forward + k_i (i_ref - i),
    limited to +-V_max. `relative_speed` is the wheel's speed relative to the body [rad/s].
    """
    i_max = p[P_IMAX]
    i_ref = min(max(torque_cmd * p[D_INV_NK], -i_max), i_max)
    v = p[P_RA] * i_ref + p[D_NK] * relative_speed + p[P_KI] * (i_ref - current)
    v_max = p[P_VMAX]
    return min(max(v, -v_max), v_max)


@_jit
def current_rate(p, voltage, current, relative_speed):
    """di/dt [A/s] of the armature: L di/dt + R i = V - k N (gamma_dot - theta_dot)."""
    return (voltage - p[P_RA] * current - p[D_NK] * relative_speed) * p[D_INV_LA]


@_jit
def wheel_rates(p, x_dot, yaw_rate):
    """(gamma_dot_L, gamma_dot_R) from pure rolling [rad/s]."""
    half = yaw_rate * p[D_HALF_D]
    return (x_dot - half) * p[D_INV_R], (x_dot + half) * p[D_INV_R]


@_jit
def derivatives(p, s, cmd_left, cmd_right, out):
    """Time derivative of state `s` under commanded wheel torques, written into `out`."""
    x_dot = s[S_XD]
    pitch_rate = s[S_THD]
    yaw = s[S_PSI]
    yaw_rate = s[S_PSID]
    rate_l, rate_r = wheel_rates(p, x_dot, yaw_rate)
    rel_l = rate_l - pitch_rate
    rel_r = rate_r - pitch_rate
    i_l = s[S_IL]
    i_r = s[S_IR]
    v_l = driver_voltage(p, cmd_left, i_l, rel_l)
    v_r = driver_voltage(p, cmd_right, i_r, rel_r)
    n_k = p[D_NK]
    x_ddot, pitch_ddot, yaw_ddot = mechanical_accelerations(
        p, x_dot, s[S_TH], pitch_rate, yaw_rate, n_k * i_l, n_k * i_r
    )
    out[S_X] = x_dot
    out[S_XD] = x_ddot
    out[S_TH] = pitch_rate
    out[S_THD] = pitch_ddot
    out[S_PSI] = yaw_rate
    out[S_PSID] = yaw_ddot
    out[S_XC] = x_dot * math.cos(yaw)
    out[S_YC] = x_dot * math.sin(yaw)
    out[S_GL] = rate_l
    out[S_GR] = rate_r
    out[S_IL] = current_rate(p, v_l, i_l, rel_l)
    out[S_IR] = current_rate(p, v_r, i_r, rel_r)


@_jit
def substeps(p, h):
    """RK4 sub-steps per step of length h so the electrical pole (R + k_i)/L stays stable."""
    lam = (p[P_RA] + p[P_KI]) / p[P_LA]
    return max(1, int(math.ceil(h * lam / RK4_SAFE_H_LAMBDA)))  # noqa: RUF046 - numba typing


@_jit
def _rk4(p, s, cmd_left, cmd_right, h, work):
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    trial = work[4]
    n = s.shape[0]
    derivatives(p, s, cmd_left, cmd_right, k1)
    for j in range(n):
        trial[j] = s[j] + 0.5 * h * k1[j]
    derivatives(p, trial, cmd_left, cmd_right, k2)
    for j in range(n):
        trial[j] = s[j] + 0.5 * h * k2[j]
    derivatives(p, trial, cmd_left, cmd_right, k3)
    for j in range(n):
        trial[j] = s[j] + h * k3[j]
    derivatives(p, trial, cmd_left, cmd_right, k4)
    for j in range(n):
        s[j] += (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])


@_jit
def rk4_step(p, s, cmd_left, cmd_right, h, work):
    """Advance state `s` in place by h seconds, commands held (zero-order hold), sub-stepping as needed."""
    n_sub = substeps(p, h)
    hs = h / n_sub
    for _ in range(n_sub):
        _rk4(p, s, cmd_left, cmd_right, hs, work)


@_jit
def advance_upright(p, s, cmd_left, cmd_right, h, n_steps, work):
    """n_steps of rk4_step unless the robot falls (|pitch| > fall_limit): then it lies still, since no
    ground contact is modelled, and the result is True. The simulator and the batch engine step with it."""
    for _ in range(n_steps):
        rk4_step(p, s, cmd_left, cmd_right, h, work)
        if abs(s[S_TH]) > p[P_FALL]:
            s[S_XD] = 0.0
            s[S_THD] = 0.0
            s[S_PSID] = 0.0
            s[S_IL] = 0.0
            s[S_IR] = 0.0
            return True
    return False


@_jit
def simulate(p, s, cmd_left, cmd_right, h, n_steps, work):
    """n_steps of rk4_step with constant commands (benchmarks and tests)."""
    for _ in range(n_steps):
        rk4_step(p, s, cmd_left, cmd_right, h, work)


@parallel_kernel
def step_batch(params, states, commands, h, n_steps):
    """Advance N robots by n_steps each: params (N, N_PARAMS), states (N, N_STATE), commands (N, 2)."""
    n = states.shape[0]
    for i in prange(n):
        work = np.empty((WORK_ROWS, N_STATE))
        for _ in range(n_steps):
            rk4_step(params[i], states[i], commands[i, 0], commands[i, 1], h, work)


def new_work() -> np.ndarray:
    return np.zeros((WORK_ROWS, N_STATE))


def initial_state(x_c: float = 0.0, y_c: float = 0.0, yaw: float = 0.0, pitch: float = 0.0) -> np.ndarray:
    s = np.zeros(N_STATE)
    s[S_XC] = x_c
    s[S_YC] = y_c
    s[S_PSI] = yaw
    s[S_TH] = pitch
    return s


def wheel_torques(p: np.ndarray, s: np.ndarray) -> tuple[float, float]:
    """Torques the motors deliver to the wheels now [N*m] (N k i)."""
    n_k = p[P_N] * p[P_KM]
    return float(n_k * s[S_IL]), float(n_k * s[S_IR])


def state_derivative(p: np.ndarray, s: np.ndarray, cmd_left: float, cmd_right: float) -> np.ndarray:
    out = np.empty(N_STATE)
    derivatives(p, s, cmd_left, cmd_right, out)
    return out


def mechanical_energy(p: np.ndarray, s: np.ndarray) -> float:
    """Kinetic + potential energy of the 3-DOF model (conserved without torque and friction) [J]."""
    r, d, l, m_b = p[P_R], p[P_D], p[P_L], p[P_MB]
    a = m_b + 2 * p[P_MW] + 2 * p[P_J] / r**2
    c2 = p[P_I2] + m_b * l * l
    dd = p[P_I3] - p[P_I1] - m_b * l * l
    sn, cs = math.sin(s[S_TH]), math.cos(s[S_TH])
    yaw_inertia = p[P_I3] + 2 * p[P_K] + (p[P_MW] + p[P_J] / r**2) * d * d / 2 - dd * sn * sn
    return float(
        0.5 * a * s[S_XD] ** 2
        + m_b * l * cs * s[S_XD] * s[S_THD]
        + 0.5 * c2 * s[S_THD] ** 2
        + 0.5 * yaw_inertia * s[S_PSID] ** 2
        + m_b * p[P_G] * l * cs
    )
