"""The LQR law: its design on the linearised model, and the law in the controller kernel."""

import numpy as np
import pytest
import scipy.signal

from twbr_common.params import ConfigError, defaults
from twbr_control.cascade import CascadeController
from twbr_control.controller_params import CONTROL_SPECS, resolve
from twbr_control.lqr import design, linear_models
from twbr_sim.robot_params import ROBOT_SPECS, robot_from_file

LQR = {"controller": "lqr"}


def closed_loop_poles(settings, robot):
    gains = design(settings, robot)
    a, b, a_yaw, b_yaw = linear_models(robot)
    period = 1.0 / settings["rate"]
    poles = []
    for (aa, bb), k in (((a, b), [gains["position"], gains["velocity"], gains["pitch"], gains["pitch_rate"]]),
                        ((a_yaw, b_yaw), [gains["heading"], gains["yaw_rate"]])):
        ad, bd, *_ = scipy.signal.cont2discrete((aa, bb, np.eye(len(aa)), np.zeros((len(aa), 1))), period, "zoh")
        poles.append(np.linalg.eigvals(ad - bd @ np.array([k])))
    return poles


def test_the_designed_gains_stabilise_the_linearised_robot():
    """The model alone is unstable (the inverted pendulum's pole, 7.6 1/s); with the gains every discrete pole
    is inside the unit circle, for the nominal robot the gains are designed on."""
    robot = defaults(ROBOT_SPECS)
    a, *_ = linear_models({**robot, "wheel_friction": 0.0})
    assert np.linalg.eigvals(a).real.max() == pytest.approx(7.5717, abs=1e-3)  # dynamics.md, friction-free
    for poles in closed_loop_poles(resolve(LQR), robot):
        assert np.abs(poles).max() < 1.0


def test_the_gains_come_from_the_robot_file(tmp_path):
    light = tmp_path / "robot.yaml"
    light.write_text("/**/sim_node:\n  ros__parameters:\n    body_mass: 6.0\n")
    assert robot_from_file(str(light))["body_mass"] == 6.0
    heavy, nominal = design(resolve({**LQR, "lqr.robot_file": str(light)})), design(resolve(LQR))
    assert heavy["pitch"] != nominal["pitch"]
    with pytest.raises(ConfigError, match=r"lqr\.robot_file"):
        design(resolve({**LQR, "lqr.robot_file": str(tmp_path / "missing.yaml")}))


def test_the_lqr_law_catches_a_lean_and_turns_like_the_cascade():
    """Signs as the cascade's: a forward lean is caught by driving forward; omega_ref > 0 drives the right
    wheel harder; torques stay within max_wheel_torque."""
    c = CascadeController(resolve(LQR))
    out = c.compute(0.0, 0.0, 0.0, 0.0, 0.0, 0.05, 0.0)
    assert out.common_torque > 0.0
    c = CascadeController(resolve(LQR))
    out = c.compute(0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)
    assert out.right_torque > out.left_torque
    c = CascadeController(resolve({**LQR, "max_wheel_torque": 3.0}))
    out = c.compute(0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 3.0)
    assert abs(out.left_torque) <= 3.0 and out.torque_saturated


def test_the_lqr_step_meets_the_paper_on_the_nonlinear_model():
    from twbr_batch.tuning import check_step, velocity_step, yaw_rate_step

    gains = {**defaults(CONTROL_SPECS), **LQR}
    v = check_step(velocity_step(gains), "velocity", "velocity_ref")
    assert not v.fallen
    assert v.response.settle_time_s <= 1.5 and v.response.steady_state_error_pct < 2.0
    assert v.response.undershoot <= 0.5 * 0.1 + 1e-9  # the roll-back: at most half the step
    w = check_step(yaw_rate_step(gains), "yaw_rate", "yaw_rate_ref")
    assert w.response.settle_time_s <= 1.5 and w.response.steady_state_error_pct < 2.0


def test_the_integral_does_not_wind_up_while_the_torque_is_saturated():
    """Held against the torque limit for 2 s (a wall), the integral of the speed error stops growing, so the
    robot does not lurch once free; below the limit the same controller integrates the error."""
    from twbr_control.cascade import K_LQR_POSITION

    held = {**LQR, "max_wheel_torque": 2.7, "reference_rate.velocity": 0.0}

    def integral_after(velocity_ref: float, steps: int) -> tuple[float, bool]:
        c = CascadeController(resolve(held))
        for k in range(steps):
            out = c.compute(0.005 * k, velocity_ref, 0.0, 0.0, 0.0, 0.0, 0.0)
        return float(c.k[K_LQR_POSITION]), out.torque_saturated

    free, saturated = integral_after(0.05, 40)  # 0.2 s of a 0.05 m/s error, well inside the limit
    assert not saturated and free == pytest.approx(-0.05 * 0.2, rel=0.05)
    wound, saturated = integral_after(1.0, 400)  # 2 s of a 1 m/s error: 2 m without anti-windup
    assert saturated and abs(wound) <= 1.0 * 0.005  # at most the one step that reached the limit


def test_the_start_up_line_names_the_law_that_runs():
    from twbr_control.controller_params import describe

    assert describe(resolve(LQR)).startswith("LQR on the linearised model")
    assert "PID" not in describe(resolve(LQR))
    assert describe(resolve({})).startswith("cascaded PID (speed -> pitch -> torque, K_p 0.4129 / 48.81)")
