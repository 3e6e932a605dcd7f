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

from twbr_common.jit import inline_kernel, kernel, lane_kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_common.trig import sincos
from twbr_sim.dynamics import S_IL, S_IR, S_PSID, S_TH, S_THD, S_XD, column, lane_wheel_rates
from twbr_sim.robot_params import D_HALF_D, D_INV_R, D_NK, P_CA, P_D, P_G, P_J, P_L, P_MB, P_MW, P_R

TRACTION_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("traction.friction", 0.8, "wheel-ground friction coefficient mu: a wheel whose friction demand"
              " exceeds mu times its normal force is reported slipping (sim_status; the motion is unchanged)",
              "", 0.0, 10.0, low_open=True),
)

OUTPUT_LAYOUT = Layout(("normal_left", "normal_right", "demand_left", "demand_right"))
TF_NORMAL_LEFT = OUTPUT_LAYOUT["normal_left"]  # [N]
TF_NORMAL_RIGHT = OUTPUT_LAYOUT["normal_right"]
TF_DEMAND_LEFT = OUTPUT_LAYOUT["demand_left"]  # horizontal ground force the wheel needs [N]
TF_DEMAND_RIGHT = OUTPUT_LAYOUT["demand_right"]
N_OUTPUTS = len(OUTPUT_LAYOUT)


@lane_kernel
def lane_wheel_loads(p, i, s, ds, out):
    """Normal forces and friction demands of lane i (structure of arrays, as dynamics.lane_derivatives) for
    its state s[:, i] and derivative ds[:, i], into out[:, i] (T_*). Plain arithmetic (the dynamics' sincos,
    sqrt for the demands' magnitude), so the batch computes it vectorised over its robots."""
    pitch = s[S_TH, i]
    sn, cs = sincos(pitch)
    pitch_rate = s[S_THD, i]
    yaw_rate = s[S_PSID, i]
    x_dot = s[S_XD, i]
    x_ddot = ds[S_XD, i]
    pitch_ddot = ds[S_THD, i]
    yaw_ddot = ds[S_PSID, i]
    l = p[P_L, i]
    m_b = p[P_MB, i]
    m_w = p[P_MW, i]
    r = p[P_R, i]
    # Vertical: the body's centre of mass at height r + l cos(theta).
    z_ddot = -l * (sn * pitch_ddot + cs * pitch_rate * pitch_rate)
    total = (m_b + 2.0 * m_w) * p[P_G, i] + m_b * z_ddot
    # Lateral accelerations (+ to the left): the axle's centripetal one, and the centre of mass's, which sits
    # l sin(theta) ahead of the axle.
    a_axle = x_dot * yaw_rate
    a_body = a_axle + l * (sn * yaw_ddot + 2.0 * cs * pitch_rate * yaw_rate)
    lateral = m_b * a_body + 2.0 * m_w * a_axle
    transfer = (m_b * a_body * (r + l * cs) + 2.0 * m_w * a_axle * r) / p[P_D, i]
    normal_l = 0.5 * total - transfer
    normal_r = 0.5 * total + transfer
    # Longitudinal: J gamma_ddot = tau - c_alpha (gamma_dot - theta_dot) - F r.
    rate_l, rate_r = lane_wheel_rates(p, i, x_dot, yaw_rate)
    half = yaw_ddot * p[D_HALF_D, i]
    acc_l = (x_ddot - half) * p[D_INV_R, i]
    acc_r = (x_ddot + half) * p[D_INV_R, i]
    f_l = (p[D_NK, i] * s[S_IL, i] - p[P_CA, i] * (rate_l - pitch_rate) - p[P_J, i] * acc_l) / r
    f_r = (p[D_NK, i] * s[S_IR, i] - p[P_CA, i] * (rate_r - pitch_rate) - p[P_J, i] * acc_r) / r
    share_l = 0.5
    if total > 0.0:
        share_l = min(max(normal_l / total, 0.0), 1.0)
    lateral_l = share_l * lateral
    lateral_r = (1.0 - share_l) * lateral
    out[TF_NORMAL_LEFT, i] = normal_l
    out[TF_NORMAL_RIGHT, i] = normal_r
    out[TF_DEMAND_LEFT, i] = math.sqrt(f_l * f_l + lateral_l * lateral_l)
    out[TF_DEMAND_RIGHT, i] = math.sqrt(f_r * f_r + lateral_r * lateral_r)


@inline_kernel
def wheel_loads(p, s, ds, out):
    """Normal forces and friction demands for state `s` and its derivative `ds`, into `out` (T_*)."""
    lane_wheel_loads(column(p), 0, column(s), column(ds), column(out))


@kernel
def traction_flags(out, friction):
    """(a wheel lifted, a wheel slipping) from wheel_loads' output: lifted means normal force <= 0."""
    lifted = out[TF_NORMAL_LEFT] <= 0.0 or out[TF_NORMAL_RIGHT] <= 0.0
    slipping = (out[TF_DEMAND_LEFT] > friction * max(out[TF_NORMAL_LEFT], 0.0)
                or out[TF_DEMAND_RIGHT] > friction * max(out[TF_NORMAL_RIGHT], 0.0))
    return lifted, slipping
