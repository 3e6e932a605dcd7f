"""The robot's physical and motor parameters (dynamics.md), as specs and as the array the kernels take.

The kernels in `dynamics` are compiled with numba and take the parameters as one float64 vector
(or one row per robot in a batch), laid out by ROBOT_LAYOUT: the parameters by their spec names (`P_*`
indices), followed by constants derived from them once (`D_*`: inertia sums, reciprocals) so that the integrator, which
evaluates the model four times per step, divides twice per evaluation instead of sixteen times.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ConfigError, ParamSpec, defaults, validate_all

ROBOT_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("gravity", 9.81, "gravitational acceleration g", "m/s^2", 0.0, 100.0),
    ParamSpec("wheel_radius", 0.10, "wheel radius r", "m", 0.0, 5.0, low_open=True),
    ParamSpec("wheel_separation", 0.40, "distance between the wheels d", "m", 0.0, 10.0, low_open=True),
    ParamSpec("com_height", 0.30, "axle to body centre of mass l", "m", 0.0, 10.0),
    ParamSpec("body_mass", 12.0, "body mass m_B", "kg", 0.0, 1e4, low_open=True),
    ParamSpec("wheel_mass", 1.0, "mass of one wheel m_W", "kg", 0.0, 1e3, low_open=True),
    ParamSpec("wheel_inertia", 0.005, "wheel inertia about its axle J", "kg*m^2", 0.0, 1e3),
    ParamSpec("wheel_yaw_inertia", 0.0027, "wheel inertia about the vertical axis K", "kg*m^2", 0.0, 1e3),
    ParamSpec("body_inertia_roll", 0.49, "body inertia about x at its centre of mass I_1", "kg*m^2", 0.0, 1e4),
    ParamSpec("body_inertia_pitch", 0.40, "body inertia about y at its centre of mass I_2", "kg*m^2", 0.0, 1e4),
    ParamSpec("body_inertia_yaw", 0.17, "body inertia about z at its centre of mass I_3", "kg*m^2", 0.0, 1e4),
    ParamSpec("wheel_friction", 0.01, "viscous friction between wheel and body c_alpha", "N*m*s/rad", 0.0, 100.0),
    ParamSpec("motor_constant", 0.05, "motor torque and back-EMF constant k", "N*m/A", 0.0, 10.0, low_open=True),
    ParamSpec("gear_ratio", 20.0, "gear ratio N (motor turns per wheel turn)", "", 0.0, 1e4, low_open=True),
    ParamSpec("armature_resistance", 0.6, "armature resistance R", "ohm", 0.0, 1e3, low_open=True),
    ParamSpec("armature_inductance", 0.0012, "armature inductance L", "H", 0.0, 10.0, low_open=True),
    ParamSpec("supply_voltage", 24.0, "motor driver supply voltage V_max", "V", 0.0, 1e3, low_open=True),
    ParamSpec("current_limit", 15.0, "motor driver current limit I_max", "A", 0.0, 1e3, low_open=True),
    ParamSpec("current_loop_gain", 1.2, "proportional gain k_i of the driver's current loop", "V/A", 0.0, 1e4),
    ParamSpec("robot_radius", 0.30, "footprint radius for collision checks", "m", 0.0, 10.0, low_open=True),
    ParamSpec("fall_limit", 0.8, "|pitch| beyond which the robot has fallen", "rad", 0.0, 1.5707963267948966, low_open=True),
)

ROBOT_PARAM_NAMES: tuple[str, ...] = tuple(s.name for s in ROBOT_SPECS)
# Constants derived once from the parameters (dynamics.md's combinations), after them in the vector.
DERIVED_NAMES: tuple[str, ...] = (
    "inv_wheel_radius", "translational_mass", "pitch_inertia_axle", "yaw_coupling", "body_moment", "gravity_moment",
    "friction_2_r", "yaw_damping", "yaw_inertia_upright", "separation_2r", "half_separation", "motor_gain",
    "inv_motor_gain", "inv_inductance",
)
ROBOT_LAYOUT = Layout(ROBOT_PARAM_NAMES + DERIVED_NAMES)
P_G = ROBOT_LAYOUT["gravity"]
P_R = ROBOT_LAYOUT["wheel_radius"]
P_D = ROBOT_LAYOUT["wheel_separation"]
P_L = ROBOT_LAYOUT["com_height"]
P_MB = ROBOT_LAYOUT["body_mass"]
P_MW = ROBOT_LAYOUT["wheel_mass"]
P_J = ROBOT_LAYOUT["wheel_inertia"]
P_K = ROBOT_LAYOUT["wheel_yaw_inertia"]
P_I1 = ROBOT_LAYOUT["body_inertia_roll"]
P_I2 = ROBOT_LAYOUT["body_inertia_pitch"]
P_I3 = ROBOT_LAYOUT["body_inertia_yaw"]
P_CA = ROBOT_LAYOUT["wheel_friction"]
P_KM = ROBOT_LAYOUT["motor_constant"]
P_N = ROBOT_LAYOUT["gear_ratio"]
P_RA = ROBOT_LAYOUT["armature_resistance"]
P_LA = ROBOT_LAYOUT["armature_inductance"]
P_VMAX = ROBOT_LAYOUT["supply_voltage"]
P_IMAX = ROBOT_LAYOUT["current_limit"]
P_KI = ROBOT_LAYOUT["current_loop_gain"]
P_ROBOT_RADIUS = ROBOT_LAYOUT["robot_radius"]
P_FALL = ROBOT_LAYOUT["fall_limit"]
D_INV_R = ROBOT_LAYOUT["inv_wheel_radius"]
D_A = ROBOT_LAYOUT["translational_mass"]
D_C2 = ROBOT_LAYOUT["pitch_inertia_axle"]
D_DD = ROBOT_LAYOUT["yaw_coupling"]
D_ML = ROBOT_LAYOUT["body_moment"]
D_MGL = ROBOT_LAYOUT["gravity_moment"]
D_CA2_R = ROBOT_LAYOUT["friction_2_r"]
D_YAW_DAMPING = ROBOT_LAYOUT["yaw_damping"]
D_YAW_INERTIA0 = ROBOT_LAYOUT["yaw_inertia_upright"]
D_D_2R = ROBOT_LAYOUT["separation_2r"]
D_HALF_D = ROBOT_LAYOUT["half_separation"]
D_NK = ROBOT_LAYOUT["motor_gain"]
D_INV_NK = ROBOT_LAYOUT["inv_motor_gain"]
D_INV_LA = ROBOT_LAYOUT["inv_inductance"]
N_SPEC_PARAMS = len(ROBOT_PARAM_NAMES)
N_PARAMS = len(ROBOT_LAYOUT)


def robot_params(values: Mapping[str, Any] | None = None) -> np.ndarray:
    """Validated parameter vector from a mapping of names (missing ones take dynamics.md's defaults)."""
    checked = validate_all(ROBOT_SPECS, dict(values or {}))
    p = np.zeros(N_PARAMS)
    p[:N_SPEC_PARAMS] = [float(checked[name]) for name in ROBOT_PARAM_NAMES]
    check_consistent(p)
    derive(p)
    return p


def derive(p: np.ndarray) -> None:
    """Fill the D_* entries of a parameter vector from its P_* entries (dynamics.md's combinations)."""
    r, d, l, m_b = p[P_R], p[P_D], p[P_L], p[P_MB]
    p[D_INV_R] = 1.0 / r
    p[D_A] = m_b + 2.0 * p[P_MW] + 2.0 * p[P_J] / (r * r)  # translational mass
    p[D_C2] = p[P_I2] + m_b * l * l  # body pitch inertia about the axle
    p[D_DD] = p[P_I3] - p[P_I1] - m_b * l * l
    p[D_ML] = m_b * l
    p[D_MGL] = m_b * p[P_G] * l
    p[D_CA2_R] = 2.0 * p[P_CA] / r
    p[D_YAW_DAMPING] = p[P_CA] * (d * d / (2.0 * r * r))
    p[D_YAW_INERTIA0] = p[P_I3] + 2.0 * p[P_K] + (p[P_MW] + p[P_J] / (r * r)) * d * d / 2.0
    p[D_D_2R] = d / (2.0 * r)
    p[D_HALF_D] = d / 2.0
    p[D_NK] = p[P_N] * p[P_KM]
    p[D_INV_NK] = 1.0 / p[D_NK]
    p[D_INV_LA] = 1.0 / p[P_LA]


def check_consistent(p: np.ndarray) -> None:
    """Refuse combinations that are each in range but make no physical sense together."""
    # The pitch equation's effective inertia about the axle must stay positive at every pitch.
    a = p[P_MB] + 2 * p[P_MW] + 2 * p[P_J] / p[P_R] ** 2
    b = p[P_MB] * p[P_L]
    c2 = p[P_I2] + p[P_MB] * p[P_L] ** 2
    if a * c2 - b * b <= 0.0:
        raise ConfigError("inconsistent parameters: body_inertia_pitch must be > 0 when com_height > 0")
    if p[P_ROBOT_RADIUS] < p[P_D] / 2:
        raise ConfigError(
            f"invalid parameter 'robot_radius' = {p[P_ROBOT_RADIUS]:g}: must be >= wheel_separation/2"
            f" = {p[P_D] / 2:g} m (the wheels must be inside the footprint)"
        )


@kernel
def wheel_torque_limit(p: np.ndarray) -> float:
    """Largest wheel torque the driver can command: N k I_max [N*m] (compiled: the batch engine calls it)."""
    return p[P_N] * p[P_KM] * p[P_IMAX]


def top_wheel_speed(p: np.ndarray) -> float:
    """Wheel speed at which back-EMF equals the supply voltage: V_max / (N k) [rad/s]."""
    return float(p[P_VMAX] / (p[P_N] * p[P_KM]))


def robot_from_file(path: str, parameter: str = "robot_file") -> dict[str, Any]:
    """The robot parameters of a robot.yaml (its sim_node section), validated; '' is the installed one.
    `parameter` names the parameter that gave the path, for the error."""
    from twbr_common.param_files import node_parameters
    from twbr_common.paths import config_dir

    file = Path(path) if path else config_dir() / "robot.yaml"
    if not file.is_file():
        raise ConfigError(f"invalid parameter '{parameter}' = {path!r}: no such file")
    known = {s.name for s in ROBOT_SPECS}
    values = {k: v for k, v in node_parameters(file, "sim_node").items() if k in known}
    return validate_all(ROBOT_SPECS, {**defaults(ROBOT_SPECS), **values})
