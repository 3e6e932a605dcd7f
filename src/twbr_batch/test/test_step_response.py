"""The paper's step responses on the nonlinear model, through the controller core and the simulator core.

These are the issue's requirements measured on the headless closed loop (the same cores the nodes run);
test/test_e2e_runner.py checks the same figures through the real nodes and the recorded bag.
"""

import numpy as np
import pytest

from twbr_batch.response import settle_time, step_response
from twbr_batch.tuning import check_step, lqr_balance_gains, velocity_step, yaw_rate_step
from twbr_common.param_files import node_parameters
from twbr_common.params import defaults
from twbr_control.controller_params import CONTROL_SPECS

GAINS = defaults(CONTROL_SPECS)  # the shipped gains (== config/controller.yaml, checked below)
TORQUE_LIMIT = 15.0


@pytest.fixture(scope="module")
def v_step():
    return velocity_step(GAINS, duration=6.0)


def test_velocity_step_meets_the_papers_figure_6(v_step):
    check = check_step(v_step, "velocity", "velocity_ref")
    r = check.response
    assert not check.fallen
    assert r.undershoot > 0.005  # it first rolls back (non-minimum phase) ...
    assert r.undershoot <= 0.5 * 0.1  # ... "slightly backwards": at most half the step (issue 17)
    assert r.settle_time_s <= 1.5  # within 5 % of 0.1 m/s within 1.5 s and stays there
    assert r.overshoot_pct < 20.0
    assert r.steady_state_error_pct < 2.0
    assert abs(check.pitch_final_rad) < 0.005 and check.pitch_settle_time_s < 3.0  # back to its equilibrium
    assert check.max_torque_nm < TORQUE_LIMIT
    assert v_step["pitch"].max() > 0.01  # it leaned forward to go forward


def test_yaw_rate_step_is_tracked_within_1_5_s_without_losing_balance():
    check = check_step(yaw_rate_step(GAINS), "yaw_rate", "yaw_rate_ref")
    assert not check.fallen
    assert check.response.settle_time_s <= 1.5
    assert check.response.steady_state_error_pct < 2.0
    assert check.max_abs_pitch_rad < 0.05


def test_combined_turn_and_drive_and_a_large_step_stay_balanced():
    from twbr_batch.closed_loop import run_closed_loop

    trace = run_closed_loop(6.0, lambda t, _s: (0.8, 1.0) if t >= 0.5 else (0.0, 0.0), GAINS)
    assert not trace.fallen
    tail = trace.t > 4.0
    assert np.abs(trace["velocity"][tail] - 0.8).max() < 0.04
    assert np.abs(trace["yaw_rate"][tail] - 1.0).max() < 0.05


def test_untuned_lqr_start_is_worse_than_the_shipped_gains():
    """The tuner earned its keep: on its own cost (settling, overshoot, roll-back past half the step, over the
    three robots with ideal sensors and six realistic-sensor runs) the shipped gains beat its LQR start."""
    from twbr_batch.tuning import _balance_cost, tuning_cases

    start = {**GAINS, **lqr_balance_gains(), "velocity.setpoint_weight": 0.5, "reference_rate.velocity": 0.5}
    cases = tuning_cases(sensors=True)
    cost = [np.mean([_balance_cost(case.velocity_step(g)) for case in cases]) for g in (start, GAINS)]
    assert cost[1] < cost[0]


def test_config_file_carries_the_shipped_gains():

    from twbr_common.paths import config_dir

    params = node_parameters(config_dir() / "controller.yaml", "controller_node")
    for name in ("pitch.kp", "pitch.kd", "velocity.kp", "velocity.ki", "velocity.setpoint_weight",
                 "reference_rate.velocity", "yaw_rate.kp", "yaw_rate.ki", "lqr.q_position", "lqr.q_velocity",
                 "lqr.q_pitch", "lqr.q_pitch_rate", "lqr.setpoint_weight", "lqr.q_heading", "lqr.q_yaw_rate"):
        assert params[name] == GAINS[name], name


def test_step_response_figures_on_a_known_signal():
    t = np.arange(0, 5, 0.01)
    ref = np.where(t >= 1.0, 2.0, 0.0)
    y = np.where(t >= 1.0, 2.0 * (1 - np.exp(-(t - 1.0) / 0.2)), 0.0)
    r = step_response(t, y, ref)
    # 5 % band: exp(-T/0.2) <= 0.05 -> T = 0.2 ln 20 = 0.599 s
    assert r.settle_time_s == pytest.approx(0.2 * np.log(20), abs=0.011)
    assert r.overshoot_pct == 0.0 and r.undershoot == 0.0
    dip = y - np.where(t >= 1.0, 0.5 * np.exp(-(t - 1.0) / 0.02), 0.0)  # starts the wrong way
    assert step_response(t, dip, ref).undershoot == pytest.approx(0.5)
    assert settle_time(t, np.ones_like(t), 0.0, 0.1, 0.0) == float("inf")
