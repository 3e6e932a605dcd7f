"""Nonlinear TWBR dynamics with a DC motor and current-loop driver per wheel (dynamics.md).

One implementation serves every user: the equations are written for one lane of a structure of arrays
(`lane_derivatives`). `rk4_step` advances one robot in place (a group of one lane), so the simulator node
calls it at 1 kHz; `step_batch` and the batch engine step groups of robots together through the same
equations (`rk4_lanes`, `advance_upright_lanes`: loops over the robots that the compiler vectorises), in
parallel; the benchmarks time both. Nothing here allocates per step.

State vector (S_* indices): forward travel x, its rate, pitch theta, its rate, yaw psi, its rate, the
axle centre's position (x_c, y_c) in odom, the wheel angles gamma_L, gamma_R, and the two armature
currents. The wheel torque is the motor's, N k i, never the command.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import inline_kernel, kernel, lane_kernel, parallel_kernel, prange
from twbr_common.layout import Layout
from twbr_common.trig import sincos
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
_lane = lane_kernel


# The equations are written once, for lane i of a structure of arrays: p[k, i] is parameter k of robot i,
# s[k, j] state k of robot j. The batch steps a group of robots together with them, in loops over the
# robots that the compiler vectorises; the scalar kernels below call them on one robot, seen as a group of
# one (column(p), lane 0), so every robot of every user runs the very same equations.


@_jit
def column(a):
    """A vector as a structure of arrays of one lane: a (n, 1) view of it."""
    return a[:, None]


@_lane
def lane_accelerations(p, i, x_dot, pitch, pitch_rate, yaw_rate, torque_left, torque_right):
    """(x_ddot, pitch_ddot, yaw_ddot) of the 3-DOF model of lane i for given wheel torques [N*m]."""
    s, c = sincos(pitch)
    dd = p[D_DD, i]
    a = p[D_A, i]
    ml = p[D_ML, i]
    b = ml * c
    c2 = p[D_C2, i]
    slip = x_dot * p[D_INV_R, i] - pitch_rate
    torque_sum = torque_left + torque_right
    rhs_x = (torque_sum * p[D_INV_R, i] - p[D_CA2_R, i] * slip
             + ml * (yaw_rate * yaw_rate + pitch_rate * pitch_rate) * s)
    rhs_th = -torque_sum + 2.0 * p[P_CA, i] * slip - dd * yaw_rate * yaw_rate * s * c + p[D_MGL, i] * s
    inv_det = 1.0 / (a * c2 - b * b)
    x_ddot = (c2 * rhs_x - b * rhs_th) * inv_det
    pitch_ddot = (a * rhs_th - b * rhs_x) * inv_det
    yaw_inertia = p[D_YAW_INERTIA0, i] - dd * s * s
    yaw_ddot = (
        p[D_D_2R, i] * (torque_right - torque_left)
        - p[D_YAW_DAMPING, i] * yaw_rate
        - (ml * x_dot - 2.0 * dd * pitch_rate * c) * yaw_rate * s
    ) / yaw_inertia
    return x_ddot, pitch_ddot, yaw_ddot


@_lane
def lane_driver_voltage(p, i, torque_cmd, current, relative_speed):
    """Motor-driver current loop of lane i: the armature voltage [V] that makes the motor deliver torque_cmd.

    i_ref = T_cmd / (N k) limited to +-I_max; V = R i_ref + back-EMF feed-forward + k_i (i_ref - i),
    limited to +-V_max. `relative_speed` is the wheel's speed relative to the body [rad/s].
    """
    i_max = p[P_IMAX, i]
    i_ref = min(max(torque_cmd * p[D_INV_NK, i], -i_max), i_max)
    v = p[P_RA, i] * i_ref + p[D_NK, i] * relative_speed + p[P_KI, i] * (i_ref - current)
    v_max = p[P_VMAX, i]
    return min(max(v, -v_max), v_max)


@_lane
def lane_current_rate(p, i, voltage, current, relative_speed):
    """di/dt [A/s] of lane i's armature: L di/dt + R i = V - k N (gamma_dot - theta_dot)."""
    return (voltage - p[P_RA, i] * current - p[D_NK, i] * relative_speed) * p[D_INV_LA, i]


@_lane
def lane_wheel_rates(p, i, x_dot, yaw_rate):
    """(gamma_dot_L, gamma_dot_R) of lane i from pure rolling [rad/s]."""
    half = yaw_rate * p[D_HALF_D, i]
    return (x_dot - half) * p[D_INV_R, i], (x_dot + half) * p[D_INV_R, i]


@_lane
def lane_derivatives(p, i, s, cmd_left, cmd_right, out):
    """Time derivative of lane i's state s[:, i] under commanded wheel torques, written into out[:, i]."""
    x_dot = s[S_XD, i]
    pitch_rate = s[S_THD, i]
    sin_yaw, cos_yaw = sincos(s[S_PSI, i])
    yaw_rate = s[S_PSID, i]
    rate_l, rate_r = lane_wheel_rates(p, i, x_dot, yaw_rate)
    rel_l = rate_l - pitch_rate
    rel_r = rate_r - pitch_rate
    i_l = s[S_IL, i]
    i_r = s[S_IR, i]
    v_l = lane_driver_voltage(p, i, cmd_left, i_l, rel_l)
    v_r = lane_driver_voltage(p, i, cmd_right, i_r, rel_r)
    n_k = p[D_NK, i]
    x_ddot, pitch_ddot, yaw_ddot = lane_accelerations(
        p, i, x_dot, s[S_TH, i], pitch_rate, yaw_rate, n_k * i_l, n_k * i_r
    )
    out[S_X, i] = x_dot
    out[S_XD, i] = x_ddot
    out[S_TH, i] = pitch_rate
    out[S_THD, i] = pitch_ddot
    out[S_PSI, i] = yaw_rate
    out[S_PSID, i] = yaw_ddot
    out[S_XC, i] = x_dot * cos_yaw
    out[S_YC, i] = x_dot * sin_yaw
    out[S_GL, i] = rate_l
    out[S_GR, i] = rate_r
    out[S_IL, i] = lane_current_rate(p, i, v_l, i_l, rel_l)
    out[S_IR, i] = lane_current_rate(p, i, v_r, i_r, rel_r)


@_jit
def mechanical_accelerations(p, x_dot, pitch, pitch_rate, yaw_rate, torque_left, torque_right):
    """(x_ddot, pitch_ddot, yaw_ddot) of the 3-DOF model for given wheel torques [N*m]."""
    return lane_accelerations(column(p), 0, x_dot, pitch, pitch_rate, yaw_rate, torque_left, torque_right)


@_jit
def driver_voltage(p, torque_cmd, current, relative_speed):
    """The motor driver's armature voltage [V] for torque_cmd (lane_driver_voltage)."""
    return lane_driver_voltage(column(p), 0, torque_cmd, current, relative_speed)


@_jit
def current_rate(p, voltage, current, relative_speed):
    """di/dt [A/s] of the armature (lane_current_rate)."""
    return lane_current_rate(column(p), 0, voltage, current, relative_speed)


@_jit
def wheel_rates(p, x_dot, yaw_rate):
    """(gamma_dot_L, gamma_dot_R) from pure rolling [rad/s]."""
    return lane_wheel_rates(column(p), 0, x_dot, yaw_rate)


@inline_kernel
def derivatives(p, s, cmd_left, cmd_right, out):
    """Time derivative of state `s` under commanded wheel torques, written into `out`."""
    lane_derivatives(column(p), 0, column(s), cmd_left, cmd_right, column(out))


@_jit
def substeps(p, h):
    """RK4 sub-steps per step of length h so the electrical pole (R + k_i)/L stays stable."""
    lam = (p[P_RA] + p[P_KI]) / p[P_LA]
    return max(1, int(math.ceil(h * lam / RK4_SAFE_H_LAMBDA)))  # noqa: RUF046 - numba typing


@_jit
def _rk4(p, s, cmd_left, cmd_right, h, work):
    # One robot as a group of one lane: the views are made once per step, not per evaluation.
    pc = column(p)
    sc = column(s)
    k1 = column(work[0])
    k2 = column(work[1])
    k3 = column(work[2])
    k4 = column(work[3])
    trial = column(work[4])
    n = s.shape[0]
    lane_derivatives(pc, 0, sc, cmd_left, cmd_right, k1)
    for j in range(n):
        trial[j, 0] = s[j] + 0.5 * h * k1[j, 0]
    lane_derivatives(pc, 0, trial, cmd_left, cmd_right, k2)
    for j in range(n):
        trial[j, 0] = s[j] + 0.5 * h * k2[j, 0]
    lane_derivatives(pc, 0, trial, cmd_left, cmd_right, k3)
    for j in range(n):
        trial[j, 0] = s[j] + h * k3[j, 0]
    lane_derivatives(pc, 0, trial, cmd_left, cmd_right, k4)
    for j in range(n):
        s[j] += (h / 6.0) * (k1[j, 0] + 2.0 * k2[j, 0] + 2.0 * k3[j, 0] + k4[j, 0])


@_jit
def rk4_step(p, s, cmd_left, cmd_right, h, work):
    """Advance state `s` in place by h seconds, commands held (zero-order hold), sub-stepping as needed."""
    n_sub = substeps(p, h)
    hs = h / n_sub
    for _ in range(n_sub):
        _rk4(p, s, cmd_left, cmd_right, hs, work)


@_lane
def lane_fallen(p, i, s):
    """True when lane i's |pitch| > fall_limit; the robot then lies still (its rates and currents zeroed),
    since no ground contact is modelled."""
    if abs(s[S_TH, i]) > p[P_FALL, i]:
        s[S_XD, i] = 0.0
        s[S_THD, i] = 0.0
        s[S_PSID, i] = 0.0
        s[S_IL, i] = 0.0
        s[S_IR, i] = 0.0
        return True
    return False


@_jit
def advance_upright(p, s, cmd_left, cmd_right, h, n_steps, work):
    """n_steps of rk4_step unless the robot falls (lane_fallen): then the result is True. The simulator
    steps with it; the batch engine with advance_upright_lanes."""
    pc = column(p)
    sc = column(s)
    for _ in range(n_steps):
        rk4_step(p, s, cmd_left, cmd_right, h, work)
        if lane_fallen(pc, 0, sc):
            return True
    return False


@_jit
def simulate(p, s, cmd_left, cmd_right, h, n_steps, work):
    """n_steps of rk4_step with constant commands (benchmarks and tests)."""
    for _ in range(n_steps):
        rk4_step(p, s, cmd_left, cmd_right, h, work)


@_lane
def rk4_lanes(p, s, cmd_left, cmd_right, h, work, lanes, moving):
    """One RK4 step of length h of lanes 0..lanes-1 in place: p (N_PARAMS, L), s (N_STATE, L), the
    commands (L,), work (WORK_ROWS, N_STATE, L). The same stages as _rk4, each a loop over the robots;
    a lane whose `moving` is False is computed but keeps its state (a robot that fell or whose run ended)."""
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    trial = work[4]
    for i in range(lanes):
        lane_derivatives(p, i, s, cmd_left[i], cmd_right[i], k1)
    for j in range(N_STATE):
        for i in range(lanes):
            trial[j, i] = s[j, i] + 0.5 * h * k1[j, i]
    for i in range(lanes):
        lane_derivatives(p, i, trial, cmd_left[i], cmd_right[i], k2)
    for j in range(N_STATE):
        for i in range(lanes):
            trial[j, i] = s[j, i] + 0.5 * h * k2[j, i]
    for i in range(lanes):
        lane_derivatives(p, i, trial, cmd_left[i], cmd_right[i], k3)
    for j in range(N_STATE):
        for i in range(lanes):
            trial[j, i] = s[j, i] + h * k3[j, i]
    for i in range(lanes):
        lane_derivatives(p, i, trial, cmd_left[i], cmd_right[i], k4)
    for j in range(N_STATE):
        for i in range(lanes):
            if moving[i]:
                s[j, i] += (h / 6.0) * (k1[j, i] + 2.0 * k2[j, i] + 2.0 * k3[j, i] + k4[j, i])


LANES = 64  # robots stepped together: their work arrays (30 KiB) stay in the L1/L2 cache


@_jit
def robot_substeps(params, h):
    """Each robot's RK4 sub-steps per step of length h (substeps of each row of params): fixed by its
    parameters, so counted once, not per group and step."""
    counts = np.empty(params.shape[0], dtype=np.int64)
    for i in range(params.shape[0]):
        counts[i] = substeps(params[i], h)
    return counts


@_lane
def shared_substeps(counts, rows, lo, size):
    """The RK4 sub-steps that robots rows[lo:lo + size] all take (counts: robot_substeps); 0 when they
    differ (their group then steps robot by robot)."""
    n_sub = counts[rows[lo]]
    for j in range(1, size):
        if counts[rows[lo + j]] != n_sub:
            return 0
    return n_sub


@_lane
def lane_group(n_params):
    """A group's arrays, LANES wide: parameters, state, commands, RK4 work, moving (all True) and fell.
    Allocated with this constant shape in a parallel kernel's body, the loops over them vectorise."""
    return (np.empty((n_params, LANES)), np.empty((N_STATE, LANES)), np.empty(LANES), np.empty(LANES),
            np.empty((WORK_ROWS, N_STATE, LANES)), np.ones(LANES, dtype=np.bool_), np.zeros(LANES, dtype=np.bool_))


@_lane
def advance_upright_lanes(p, s, cmd_left, cmd_right, h, n_steps, work, lanes, moving, fell):
    """advance_upright for lanes 0..lanes-1 that are `moving` (their robots sharing substeps): a lane that
    falls stops moving and its `fell` is set."""
    n_sub = substeps(p[:, 0], h)
    hs = h / n_sub
    for _ in range(n_steps):
        for _ in range(n_sub):
            rk4_lanes(p, s, cmd_left, cmd_right, hs, work, lanes, moving)
        for i in range(lanes):
            if moving[i] and lane_fallen(p, i, s):
                moving[i] = False
                fell[i] = True


@parallel_kernel
def step_batch(params, states, commands, h, n_steps):
    """Advance N robots by n_steps each: params (N, N_PARAMS), states (N, N_STATE), commands (N, 2).

    Groups of LANES robots step together (rk4_lanes); a group whose robots need different numbers of
    sub-steps (substeps) steps robot by robot instead, so every robot's result is rk4_step's to the bit.
    """
    n = states.shape[0]
    n_params = params.shape[1]
    counts = robot_substeps(params, h)
    rows = np.arange(n)
    for g in prange((n + LANES - 1) // LANES):
        lo = g * LANES
        lanes = min(n, lo + LANES) - lo
        n_sub = shared_substeps(counts, rows, lo, lanes)
        if n_sub == 0:
            work = np.empty((WORK_ROWS, N_STATE))
            for i in range(lo, lo + lanes):
                for _ in range(n_steps):
                    rk4_step(params[i], states[i], commands[i, 0], commands[i, 1], h, work)
            continue
        p, s, left, right, work, moving, _fell = lane_group(n_params)
        for i in range(lanes):
            for k in range(n_params):
                p[k, i] = params[lo + i, k]
            for k in range(N_STATE):
                s[k, i] = states[lo + i, k]
            left[i] = commands[lo + i, 0]
            right[i] = commands[lo + i, 1]
        hs = h / n_sub
        for _ in range(n_steps * n_sub):
            rk4_lanes(p, s, left, right, hs, work, lanes, moving)
        for i in range(lanes):
            for k in range(N_STATE):
                states[lo + i, k] = s[k, i]


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
