"""The PID pieces: derivative on the measurement, its filter, limits, anti-windup, set-point weight, reset."""

import math

import pytest

from twbr_control.pid import Pid, PidGains

DT = 0.005


def test_setpoint_step_gives_no_derivative_kick():
    pid = Pid(PidGains(kp=0.0, kd=10.0))
    pid.update(0.0, 0.0, DT)
    assert pid.update(1.0, 0.0, DT) == 0.0  # the error jumped, the measurement did not


def test_derivative_acts_on_the_measurement_with_the_right_sign():
    pid = Pid(PidGains(kp=0.0, kd=2.0))
    pid.update(0.0, 0.0, DT)
    assert pid.update(0.0, 0.01, DT) == pytest.approx(-2.0 * 0.01 / DT)
    # A measured rate (a gyro) replaces the difference.
    assert Pid(PidGains(kp=0.0, kd=2.0)).update(0.0, 0.0, DT, measurement_rate=3.0) == pytest.approx(-6.0)


def test_derivative_filter_is_a_first_order_lag():
    tau = 0.02
    pid = Pid(PidGains(kp=0.0, kd=1.0, derivative_filter=tau))
    outputs = [pid.update(0.0, 0.0, DT, measurement_rate=1.0) for _ in range(200)]
    alpha = DT / (tau + DT)
    assert -outputs[0] == pytest.approx(alpha)
    # After one time constant's worth of samples: 1 - (1 - alpha)^n.
    n = round(tau / DT)
    assert -outputs[n - 1] == pytest.approx(1 - (1 - alpha) ** n)
    assert -outputs[-1] == pytest.approx(1.0, abs=1e-9)


def test_output_is_limited_and_flagged():
    pid = Pid(PidGains(kp=10.0, output_limit=2.0))
    assert pid.update(1.0, 0.0, DT) == 2.0 and pid.limited
    assert pid.update(-1.0, 0.0, DT) == -2.0 and pid.limited
    assert pid.update(0.1, 0.0, DT) == pytest.approx(1.0) and not pid.limited


def test_anti_windup_stops_the_integral_while_saturated_and_recovers_at_once():
    gains = PidGains(kp=1.0, ki=5.0, output_limit=1.0)
    pid, naive = Pid(gains), 0.0
    for _ in range(400):  # 2 s far into saturation
        pid.update(10.0, 0.0, DT)
        naive += 5.0 * 10.0 * DT
    assert pid.integral < 1.0 + 5.0 * 10.0 * DT  # not the 100 a naive integrator would hold
    assert naive == pytest.approx(100.0)
    # The error reverses: the output leaves the limit on the very next sample.
    out = pid.update(-0.5, 0.0, DT)
    assert out < 1.0


def test_hold_integral_blocks_one_direction_only():
    pid = Pid(PidGains(kp=0.0, ki=1.0))
    pid.update(1.0, 0.0, DT, hold_integral=+1)
    assert pid.integral == 0.0
    pid.update(-1.0, 0.0, DT, hold_integral=+1)
    assert pid.integral == pytest.approx(-DT)


def test_setpoint_weight_scales_only_the_proportional_reference():
    pid = Pid(PidGains(kp=2.0, ki=1.0, setpoint_weight=0.5))
    out = pid.update(1.0, 0.2, DT)
    assert out == pytest.approx(2.0 * (0.5 * 1.0 - 0.2) + 1.0 * (1.0 - 0.2) * DT)


def test_reset_forgets_everything():
    pid = Pid(PidGains(kp=1.0, ki=1.0, kd=1.0))
    for _ in range(10):
        pid.update(1.0, 0.5, DT)
    pid.reset()
    assert pid.integral == 0.0 and pid.output == 0.0
    assert pid.update(0.0, 0.3, DT) == pytest.approx(-0.3 - 0.3 * DT)  # no derivative from the old measurement


@pytest.mark.parametrize("dt", [0.0, -0.01, math.nan])
def test_bad_sample_time_is_refused(dt):
    with pytest.raises(ValueError):
        Pid(PidGains(kp=1.0)).update(1.0, 0.0, dt)
