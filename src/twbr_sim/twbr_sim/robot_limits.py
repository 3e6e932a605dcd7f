"""What the robot can physically do, from its parameters (robot.yaml): the bounds a planner's and a
controller's settings must stay within, whatever their own ranges allow.

A planner asked for 10 m/s on a robot whose motors top out at 2.4 m/s, or a controller limited to 0.01 N·m
on a robot that needs 2.6 N·m to hold its lean, is not a tuning choice but a request the robot cannot
meet: the planner then plans moves the robot does not make (into an obstacle), and the robot falls. The
bounds follow from the model's own equations (`twbr_sim.dynamics`), at rest and upright:

- top speed: the wheels' no-load speed (back-EMF equal to the supply voltage) times the wheel radius;
- top yaw rate: the wheels at opposite no-load speeds;
- largest acceleration: what the robot sustains leaning no further than its fall limit, with the wheel
  torque that holds that lean within the motors' limit (a balancing robot accelerates by leaning);
- largest yaw acceleration: the motors' limit as a differential torque;
- the torque that holds the body at a lean (a controller's pitch reference) against gravity.

Pure Python over the compiled model; no ROS.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from twbr_common.params import ConfigError, ParamSpec
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import P_D, P_FALL, P_R, robot_from_file, robot_params, top_wheel_speed, wheel_torque_limit

ROBOT_FILE_SPEC = ParamSpec(
    "robot_file", "", "robot.yaml (its sim_node section) of the robot driven: speeds, accelerations and torques"
    " the robot cannot meet are refused, at start-up and at runtime; empty: the installed config/robot.yaml")


@dataclass(frozen=True)
class RobotLimits:
    top_speed: float  # [m/s]
    top_yaw_rate: float  # [rad/s]
    max_acceleration: float  # [m/s²]
    max_yaw_acceleration: float  # [rad/s²]
    torque_limit: float  # per wheel [N·m]
    gravity_moment: float  # m_B g l [N·m]
    source: str  # where the robot's parameters came from, for the refusal

    def holding_torque(self, pitch: float) -> float:
        """Per wheel, the torque that holds the body still at `pitch` [rad] against gravity [N·m]."""
        return 0.5 * self.gravity_moment * math.sin(abs(pitch))


def robot_limits(robot: Mapping[str, Any], source: str = "robot.yaml") -> RobotLimits:
    """The limits of the robot with parameters `robot` (a robot.yaml's sim_node section, validated)."""
    p = robot_params(dict(robot))
    tau = wheel_torque_limit(p)
    top_speed = top_wheel_speed(p) * float(p[P_R])
    return RobotLimits(
        top_speed=top_speed,
        top_yaw_rate=2.0 * top_speed / float(p[P_D]),
        max_acceleration=_largest_sustained_acceleration(p, tau),
        max_yaw_acceleration=abs(dyn.mechanical_accelerations(p, 0.0, 0.0, 0.0, 0.0, -tau, tau)[2]),
        torque_limit=tau,
        gravity_moment=float(p[dyn.D_MGL]),
        source=source,
    )


def _largest_sustained_acceleration(p: np.ndarray, tau_max: float) -> float:
    """The largest forward acceleration held at a constant lean (pitch_ddot = 0) no further than the fall
    limit, with both wheels' torque within the motors' limit. The model is affine in the torque: the
    torque that holds a lean is where pitch_ddot crosses zero."""
    best = 0.0
    for pitch in np.linspace(0.0, float(p[P_FALL]), 161)[1:]:
        at = [dyn.mechanical_accelerations(p, 0.0, pitch, 0.0, 0.0, t, t) for t in (0.0, 1.0)]
        slope = at[1][1] - at[0][1]
        if slope == 0.0:
            continue
        hold = -at[0][1] / slope  # per wheel
        if abs(hold) > tau_max:
            break
        best = max(best, abs(dyn.mechanical_accelerations(p, 0.0, pitch, 0.0, 0.0, hold, hold)[0]))
    return best


@functools.lru_cache(maxsize=8)
def limits_from_file(path: str, parameter: str = "robot_file") -> RobotLimits:
    """The limits of a robot.yaml ('' the installed one); `parameter` names the parameter that gave it."""
    source = path or "the installed config/robot.yaml"
    return robot_limits(robot_from_file(path, parameter), source)


# Where each bound comes from, for the refusal.
WHY = {
    "top_speed": "the robot's top speed (wheel_radius times the no-load wheel speed supply_voltage / (gear_ratio *"
                 " motor_constant))",
    "top_yaw_rate": "the robot's top yaw rate (2 * top speed / wheel_separation)",
    "max_acceleration": "the largest acceleration the robot sustains leaning no further than fall_limit with its"
                        " motors' torque (gear_ratio * motor_constant * current_limit)",
    "max_yaw_acceleration": "the robot's largest yaw acceleration (its motors' torque limit as a differential"
                            " torque on its yaw inertia)",
}


def at_most(cfg: Mapping[str, Any], name: str, limits: RobotLimits, bound: str, unit: str) -> None:
    """Refuse cfg[name] above the robot's `bound` (a RobotLimits field), naming it and where it comes from."""
    value = getattr(limits, bound)
    if cfg[name] > value * (1.0 + 1e-12):
        raise ConfigError(f"invalid parameter '{name}' = {cfg[name]:g}: must be at most {value:.4g} {unit},"
                          f" {WHY[bound]}, of {limits.source}")
