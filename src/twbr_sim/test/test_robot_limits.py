"""The robot's physical limits, and the settings refused against them (issue 34)."""

import math

import pytest

from twbr_common.params import ConfigError, defaults
from twbr_sim import dynamics as dyn
from twbr_sim.robot_limits import limits_from_file, robot_limits
from twbr_sim.robot_params import ROBOT_SPECS, robot_params

ROBOT = defaults(ROBOT_SPECS)


def test_top_speeds_are_the_motors_no_load_speed_at_the_wheel():
    lim = robot_limits(ROBOT)
    no_load = ROBOT["supply_voltage"] / (ROBOT["gear_ratio"] * ROBOT["motor_constant"])  # 24 rad/s
    assert lim.top_speed == pytest.approx(no_load * ROBOT["wheel_radius"]) == pytest.approx(2.4)
    assert lim.top_yaw_rate == pytest.approx(2 * 2.4 / ROBOT["wheel_separation"])
    doubled = robot_limits({**ROBOT, "supply_voltage": 48.0})
    assert doubled.top_speed == pytest.approx(4.8)


def test_the_largest_acceleration_is_one_the_model_can_hold():
    """At the bound, the torque that holds the lean is within the motors' limit and the model, fed it,
    accelerates at the bound with pitch_ddot = 0; past the torque limit, more is not possible."""
    lim = robot_limits(ROBOT)
    p = robot_params(dict(ROBOT))
    # The shipped robot: the fall limit binds (0.8 rad held with 4.74 N·m per wheel, within 15 N·m).
    hold = 4.7405
    ahead = dyn.mechanical_accelerations(p, 0.0, ROBOT["fall_limit"], 0.0, 0.0, hold, hold)
    assert abs(ahead[1]) < 1e-3 and lim.max_acceleration == pytest.approx(ahead[0], rel=1e-3)
    assert 1.0 < lim.max_acceleration < ROBOT["gravity"] * math.tan(ROBOT["fall_limit"])
    assert robot_limits({**ROBOT, "current_limit": 5.0}).max_acceleration == lim.max_acceleration
    # Motors of 2 N·m per wheel hold no more than ~0.35 rad of lean: less acceleration.
    weak = robot_limits({**ROBOT, "current_limit": 2.0})
    assert 1.5 < weak.max_acceleration < 0.5 * lim.max_acceleration
    assert robot_limits({**ROBOT, "fall_limit": 0.4}).max_acceleration == pytest.approx(2.8557, rel=1e-3)


def test_the_largest_yaw_acceleration_is_the_differential_torque_on_the_yaw_inertia():
    lim = robot_limits(ROBOT)
    r, d = ROBOT["wheel_radius"], ROBOT["wheel_separation"]
    inertia = (ROBOT["body_inertia_yaw"] + 2 * ROBOT["wheel_yaw_inertia"]
               + (ROBOT["wheel_mass"] + ROBOT["wheel_inertia"] / r**2) * d * d / 2)
    assert lim.max_yaw_acceleration == pytest.approx(15.0 * d / r / inertia, rel=1e-6)


def test_holding_torque_is_gravitys_moment_on_the_lean():
    lim = robot_limits(ROBOT)
    mgl = ROBOT["body_mass"] * ROBOT["gravity"] * ROBOT["com_height"]
    assert lim.holding_torque(0.15) == pytest.approx(mgl * math.sin(0.15) / 2) == pytest.approx(2.639, abs=1e-3)


def test_planner_settings_past_the_robot_are_refused_naming_the_bound():
    from twbr_planner.planner_params import resolve

    assert resolve()["v_max"] == 0.6  # the shipped settings pass
    for name, value, text in (("v_max", 10.0, "at most 2.4 m/s, the robot's top speed"),
                              ("max_acceleration", 100.0, "largest acceleration"),
                              ("brake_deceleration", 50.0, "largest acceleration"),
                              ("window_acceleration", 50.0, "largest acceleration"),
                              ("max_yaw_rate", 20.0, "at most 12 rad/s"),
                              ("max_yaw_acceleration", 1000.0, "largest yaw acceleration")):
        with pytest.raises(ConfigError, match=f"'{name}' = .*{text}.*robot.yaml"):
            resolve({name: value})
    resolve({"v_max": 2.4, "max_yaw_rate": 12.0})  # the bound itself is allowed


def test_controller_settings_past_the_robot_are_refused_naming_the_bound():
    from twbr_control.controller_params import resolve

    resolve()
    with pytest.raises(ConfigError, match=r"'max_wheel_torque' = 0.01: must be at least 2.639 N·m"):
        resolve({"max_wheel_torque": 0.01})
    with pytest.raises(ConfigError, match=r"'max_wheel_torque' = 3: must be at least 4.09"):
        resolve({"max_wheel_torque": 3.0, "max_pitch_ref": 0.2, "pitch_offset": 0.034})
    with pytest.raises(ConfigError, match=r"'max_velocity_ref' = 5: .*top speed"):
        resolve({"max_velocity_ref": 5.0})


def test_a_robot_file_that_is_missing_is_refused_by_name():
    with pytest.raises(ConfigError, match=r"'robot_file' = '/nowhere\.yaml': no such file"):
        limits_from_file("/nowhere.yaml")
