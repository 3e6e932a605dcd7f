"""Whether the wheels still hold the ground: each wheel's normal force and the friction its motion demands.

The dynamics assume rolling without slip on both wheels (dynamics.md), whatever it takes. This says when
that stops being true of a real robot: a wheel lifts when its normal force would be <= 0, and slips when
the friction it needs exceeds mu times its normal force. It does not change the motion (an independent
multibody engine, twbr_mujoco, shows what happens then).

Normal forces: the vertical balance of body and wheels (the body's centre of mass at r + l cos(theta)
moves with pitch), split between the wheels by the roll moment of the lateral inertial forces (the body's
at its centre of mass, the wheels' at the axle). Wheel gyroscopic and body roll-inertia moments are
left out (below 2 % of the lateral load transfer at the planner's limits). Friction: each wheel's
longitudinal ground force from its spin equation (motor torque, wheel-body friction, wheel inertia); the
lateral ground force shared in proportion to the normal forces.
"""

from __future__ import annotations

import math

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.dynamics import S_IL, S_IR, S_PSID, S_TH, S_THD, S_XD, wheel_rates
from twbr_sim.robot_params import D_HALF_D, D_INV_R, D_NK, P_CA, P_D, P_G, P_J, P_L, P_MB, P_MW, P_R

TRACTION_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("traction.friction", 0.8, "wheel-ground friction coefficient mu: a wheel whose friction demand"
              " exceeds mu times its normal force is reported slipping (sim_status; the motion is unchanged)",
              "", 0.0, 10.0, low_open=True),
)

OUTPUT_LAYOUT = Layout(("normal_left", "normal_right", "demand_left", "demand_right"))
T_NORMAL_LEFT = OUTPUT_LAYOUT["normal_left"]  # [N]
T_NORMAL_RIGHT = OUTPUT_LAYOUT["normal_right"]
T_DEMAND_LEFT = OUTPUT_LAYOUT["demand_left"]  # horizontal ground force the wheel needs [N]
T_DEMAND_RIGHT = OUTPUT_LAYOUT["demand_right"]
N_OUTPUTS = len(OUTPUT_LAYOUT)


@kernel
def wheel_loads(p, s, ds, out):
    """Normal forces and friction demands for state `s` and its derivative `ds`, into `out` (T_*)."""
    pitch = s[S_TH]
    sn = math.sin(pitch)
    cs = math.cos(pitch)
    pitch_rate = s[S_THD]
    yaw_rate = s[S_PSID]
    x_dot = s[S_XD]
    x_ddot = ds[S_XD]
    pitch_ddot = ds[S_THD]
    yaw_ddot = ds[S_PSID]
    l = p[P_L]
    m_b = p[P_MB]
    m_w = p[P_MW]
    r = p[P_R]
    # Vertical: the body's centre of mass at height r + l cos(theta).
    z_ddot = -l * (sn * pitch_ddot + cs * pitch_rate * pitch_rate)
    total = (m_b + 2.0 * m_w) * p[P_G] + m_b * z_ddot
    # Lateral accelerations (+ to the left): the axle's centripetal one, and the centre of mass's, which sits
    # l sin(theta) ahead of the axle.
    a_axle = x_dot * yaw_rate
    a_body = a_axle + l * (sn * yaw_ddot + 2.0 * cs * pitch_rate * yaw_rate)
    lateral = m_b * a_body + 2.0 * m_w * a_axle
    transfer = (m_b * a_body * (r + l * cs) + 2.0 * m_w * a_axle * r) / p[P_D]
    normal_l = 0.5 * total - transfer
    normal_r = 0.5 * total + transfer
    # Longitudinal: J gamma_ddot = tau - c_alpha (gamma_dot - theta_dot) - F r.
    rate_l, rate_r = wheel_rates(p, x_dot, yaw_rate)
    half = yaw_ddot * p[D_HALF_D]
    acc_l = (x_ddot - half) * p[D_INV_R]
    acc_r = (x_ddot + half) * p[D_INV_R]
    f_l = (p[D_NK] * s[S_IL] - p[P_CA] * (rate_l - pitch_rate) - p[P_J] * acc_l) / r
    f_r = (p[D_NK] * s[S_IR] - p[P_CA] * (rate_r - pitch_rate) - p[P_J] * acc_r) / r
    share_l = 0.5
    if total > 0.0:
        share_l = min(max(normal_l / total, 0.0), 1.0)
    out[T_NORMAL_LEFT] = normal_l
    out[T_NORMAL_RIGHT] = normal_r
    out[T_DEMAND_LEFT] = math.hypot(f_l, share_l * lateral)
    out[T_DEMAND_RIGHT] = math.hypot(f_r, (1.0 - share_l) * lateral)


@kernel
def traction_flags(out, friction):
    """(a wheel lifted, a wheel slipping) from wheel_loads' output: lifted means normal force <= 0."""
    lifted = out[T_NORMAL_LEFT] <= 0.0 or out[T_NORMAL_RIGHT] <= 0.0
    slipping = (out[T_DEMAND_LEFT] > friction * max(out[T_NORMAL_LEFT], 0.0)
                or out[T_DEMAND_RIGHT] > friction * max(out[T_NORMAL_RIGHT], 0.0))
    return lifted, slipping
